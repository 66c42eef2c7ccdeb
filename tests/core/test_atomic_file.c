/* Atomic files (core/src/atomic_file.h): what a write replaces and what it never touches. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof(dir), "/tmp/vbnl_atomic_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    DIR *d = opendir(dir);
    for (struct dirent *e; d && (e = readdir(d));) {
        char p[512];
        if (e->d_name[0] == '.')
            continue;
        snprintf(p, sizeof(p), "%s/%s", dir, e->d_name);
        unlink(p);
    }
    if (d)
        closedir(d);
    rmdir(dir);
    return 0;
}

static void in_dir(const char *name, char *out, size_t n) { snprintf(out, n, "%s/%s", dir, name); }

static vbnl_result write_text(const char *path, const char *text, vbnl_error *err)
{
    vbi_atomic_file f;
    vbnl_result r = vbi_atomic_file_open(&f, path, err);
    if (r != VBNL_OK)
        return r;
    assert_int_equal(write(f.fd, text, strlen(text)), (ssize_t)strlen(text));
    return vbi_atomic_file_commit(&f, err);
}

static void expect_content(const char *path, const char *text)
{
    char buf[256] = {0};
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    size_t n = fread(buf, 1, sizeof(buf) - 1, fp);
    fclose(fp);
    assert_int_equal(n, strlen(text));
    assert_string_equal(buf, text);
}

/* Only the files of this test are in the folder: no temporary is ever left behind. */
static void expect_no_temporaries(void)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    for (struct dirent *e; (e = readdir(d));)
        assert_null(strstr(e->d_name, ".tmp-"));
    closedir(d);
}

static void test_new_and_replaced(void **state)
{
    (void)state;
    char p[512];
    in_dir("a.txt", p, sizeof(p));
    vbnl_error err = {0};
    assert_int_equal(write_text(p, "one", &err), VBNL_OK);
    expect_content(p, "one");
    assert_int_equal(write_text(p, "two!", &err), VBNL_OK);
    expect_content(p, "two!");
    expect_no_temporaries();
}

/* A replaced file keeps its permission bits: a private file stays private. */
static void test_mode_kept(void **state)
{
    (void)state;
    char p[512];
    in_dir("private.txt", p, sizeof(p));
    vbnl_error err = {0};
    assert_int_equal(write_text(p, "secret", &err), VBNL_OK);
    assert_int_equal(chmod(p, 0600), 0);
    assert_int_equal(write_text(p, "still secret", &err), VBNL_OK);
    struct stat st;
    assert_int_equal(stat(p, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0600);
    expect_content(p, "still secret");
}

/* Writing through a symbolic link replaces the file it names; the link stays a link. A link to
 * nothing is refused. */
static void test_symlink(void **state)
{
    (void)state;
    char target[512], link[512], dangling[512];
    in_dir("target.txt", target, sizeof(target));
    in_dir("link.txt", link, sizeof(link));
    in_dir("dangling.txt", dangling, sizeof(dangling));
    vbnl_error err = {0};
    assert_int_equal(write_text(target, "old", &err), VBNL_OK);
    assert_int_equal(symlink("target.txt", link), 0);
    assert_int_equal(write_text(link, "new", &err), VBNL_OK);
    struct stat st;
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    expect_content(target, "new");
    assert_int_equal(symlink("nowhere.txt", dangling), 0);
    assert_int_equal(write_text(dangling, "x", &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "symbolic link to a missing file"));
    expect_no_temporaries();
}

/* Nothing but a regular file is replaced: a FIFO (like a device) and a folder are refused before
 * anything is created, and stay what they were. */
static void test_not_regular(void **state)
{
    (void)state;
    char fifo[512], sub[512];
    in_dir("fifo", fifo, sizeof(fifo));
    in_dir("sub", sub, sizeof(sub));
    assert_int_equal(mkfifo(fifo, 0600), 0);
    assert_int_equal(mkdir(sub, 0700), 0);
    vbnl_error err = {0};
    vbi_atomic_file f;
    assert_int_equal(vbi_atomic_file_open(&f, fifo, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "not a regular file"));
    assert_int_equal(vbi_atomic_file_open(&f, "/dev/null", &err), VBNL_ERR_IO);
    assert_int_equal(vbi_atomic_file_open(&f, sub, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "is a folder"));
    struct stat st;
    assert_int_equal(lstat(fifo, &st), 0);
    assert_true(S_ISFIFO(st.st_mode));
    assert_int_equal(lstat("/dev/null", &st), 0);
    assert_true(S_ISCHR(st.st_mode));
    expect_no_temporaries();
    rmdir(sub);
}

/* A discarded write leaves the old file as it was and no temporary. */
static void test_discard_keeps_old(void **state)
{
    (void)state;
    char p[512];
    in_dir("kept.txt", p, sizeof(p));
    vbnl_error err = {0};
    assert_int_equal(write_text(p, "kept", &err), VBNL_OK);
    vbi_atomic_file f;
    assert_int_equal(vbi_atomic_file_open(&f, p, &err), VBNL_OK);
    assert_int_equal(write(f.fd, "half", 4), 4);
    vbi_atomic_file_discard(&f);
    vbi_atomic_file_discard(&f); /* twice is safe */
    expect_content(p, "kept");
    expect_no_temporaries();
}

/* After abandon_all (a signal handler's last call) the temporary of a write under way is gone,
 * its commit fails, the old file stays, and every later open fails. Final: runs last. */
static void test_abandon(void **state)
{
    (void)state;
    char p[512], q[512];
    in_dir("abandoned.txt", p, sizeof(p));
    in_dir("later.txt", q, sizeof(q));
    vbnl_error err = {0};
    assert_int_equal(write_text(p, "before", &err), VBNL_OK);
    vbi_atomic_file f;
    assert_int_equal(vbi_atomic_file_open(&f, p, &err), VBNL_OK);
    assert_int_equal(write(f.fd, "after", 5), 5);
    vbi_atomic_file_abandon_all();
    expect_no_temporaries();
    assert_int_equal(vbi_atomic_file_commit(&f, &err), VBNL_ERR_CANCELLED);
    expect_content(p, "before");
    assert_int_equal(write_text(q, "x", &err), VBNL_ERR_CANCELLED);
    assert_int_equal(access(q, F_OK), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_new_and_replaced), cmocka_unit_test(test_mode_kept),
        cmocka_unit_test(test_symlink),          cmocka_unit_test(test_not_regular),
        cmocka_unit_test(test_discard_keeps_old), cmocka_unit_test(test_abandon),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
