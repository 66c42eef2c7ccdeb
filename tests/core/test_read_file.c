/* Opening a file to read it (core/src/read_file.h): regular files are read; folders, FIFOs,
 * devices and sockets are refused at once with the reason, also through a symbolic link. A FIFO
 * opened the ordinary way would wait for a writer forever: an alarm turns such a wait into a
 * failure instead of a hung test. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "read_file.h"

static char dir[256];

static void in_dir(const char *name, char *out, size_t n) { snprintf(out, n, "%s/%s", dir, name); }

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "read_file: an open waited (a FIFO blocked it)\n";
    (void)!write(2, msg, sizeof msg - 1);
    _exit(1);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof(dir), "/tmp/vbnl_read_XXXXXX");
    signal(SIGALRM, on_alarm);
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    static const char *const names[] = {"plain", "fifo", "fifo-link", "sock", "sub"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i) {
        char p[512];
        in_dir(names[i], p, sizeof p);
        if (unlink(p) != 0)
            rmdir(p);
    }
    rmdir(dir);
    return 0;
}

/* A regular file: its descriptor and size, and the stream reads its bytes. */
static void test_regular_file(void **state)
{
    (void)state;
    char p[512];
    in_dir("plain", p, sizeof p);
    FILE *w = fopen(p, "wb");
    assert_non_null(w);
    fputs("seven b", w);
    fclose(w);
    struct stat st;
    const char *why = "unset";
    int fd = vbi_read_open(p, &st, &why);
    assert_true(fd >= 0);
    assert_null(why);
    assert_int_equal(st.st_size, 7);
    assert_int_equal(fcntl(fd, F_GETFL) & O_NONBLOCK, 0); /* cleared for the caller's reads */
    assert_true(fcntl(fd, F_GETFD) & FD_CLOEXEC);
    close(fd);
    FILE *f = vbi_read_fopen(p, NULL, &why);
    assert_non_null(f);
    char buf[16] = {0};
    assert_int_equal(fread(buf, 1, sizeof buf, f), 7);
    assert_string_equal(buf, "seven b");
    fclose(f);
}

/* A FIFO nobody writes: refused at once, directly and through a link. */
static void test_fifo_refused_without_waiting(void **state)
{
    (void)state;
    char p[512], link[512];
    in_dir("fifo", p, sizeof p);
    in_dir("fifo-link", link, sizeof link);
    assert_int_equal(mkfifo(p, 0600), 0);
    assert_int_equal(symlink("fifo", link), 0);
    alarm(10);
    const char *why = NULL;
    assert_int_equal(vbi_read_open(p, NULL, &why), -1);
    assert_string_equal(why, "it is a FIFO, not a regular file");
    why = NULL;
    assert_null(vbi_read_fopen(link, NULL, &why));
    assert_string_equal(why, "it is a FIFO, not a regular file");
    alarm(0);
}

static void test_special_files_refused(void **state)
{
    (void)state;
    char p[512];
    const char *why = NULL;
    assert_int_equal(vbi_read_open("/dev/null", NULL, &why), -1);
    assert_string_equal(why, "it is a device, not a regular file");
    in_dir("sub", p, sizeof p);
    assert_int_equal(mkdir(p, 0700), 0);
    assert_null(vbi_read_fopen(p, NULL, &why));
    assert_string_equal(why, "it is a folder");
    assert_int_equal(errno, EISDIR);
    in_dir("sock", p, sizeof p);
    int s = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    assert_true(strlen(p) < sizeof a.sun_path);
    memcpy(a.sun_path, p, strlen(p) + 1);
    assert_int_equal(bind(s, (struct sockaddr *)&a, sizeof a), 0);
    assert_int_equal(vbi_read_open(p, NULL, &why), -1);
    assert_string_equal(why, "it is a socket, not a regular file");
    close(s);
}

static void test_missing_file(void **state)
{
    (void)state;
    char p[512];
    in_dir("none", p, sizeof p);
    const char *why = NULL;
    assert_int_equal(vbi_read_open(p, NULL, &why), -1);
    assert_string_equal(why, strerror(ENOENT));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_regular_file),
        cmocka_unit_test(test_fifo_refused_without_waiting),
        cmocka_unit_test(test_special_files_refused),
        cmocka_unit_test(test_missing_file),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
