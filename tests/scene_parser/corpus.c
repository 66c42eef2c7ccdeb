/* vbnl: corpus check of the scene parser (language and object layers).
 *
 * Loads every .pov file under a directory (default: POV-Ray's sample scenes,
 * /usr/share/povray-3.7/scenes from Debian's povray-examples) with vbnl_pov_load_file, building
 * the core scene without committing it (the BVH build adds nothing to the parser check), each in a
 * child process with a limit of processor time (-t, and four times that of wall-clock time), and
 * prints a table: parsed clean / with warnings / error / timeout / crash, followed by the most frequent error messages, the most frequent unsupported
 * features (warnings that something is skipped or ignored) and, for every shape left out of a
 * scene ("'lathe' is not supported; the object is skipped"), the number of scenes that lose it.
 *
 *     corpus [-t seconds] [-v] [--check PERCENT] [dir]
 *
 * Exit status: 0; with --check, 1 when any scene crashed or timed out or fewer than PERCENT % of
 * the scenes parsed without error (the test suite runs it with --check 90). With --check and no
 * scenes installed it exits 77 (skip). */
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

typedef struct entry {
    char *path;
    char status[16];
    char message[600];
    char skipped[300]; /* shapes left out, '|'-separated */
    int warnings;
    double seconds;
} entry;

static entry *entries;
static size_t nentries, capentries;

static void collect(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        struct stat st;
        if (stat(path, &st) != 0)
            continue;
        if (S_ISDIR(st.st_mode)) {
            collect(path);
            continue;
        }
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".pov") != 0)
            continue;
        if (nentries == capentries) {
            capentries = capentries ? capentries * 2 : 256;
            entries = realloc(entries, capentries * sizeof *entries);
            if (!entries)
                exit(1);
        }
        memset(&entries[nentries], 0, sizeof entries[0]);
        entries[nentries++].path = strdup(path);
    }
    closedir(d);
}

static int cmp_entry(const void *a, const void *b)
{
    return strcmp(((const entry *)a)->path, ((const entry *)b)->path);
}

typedef struct child_state {
    int warnings;
    char features[600]; /* distinct "not supported"/"ignored" warnings, '|'-separated */
    char skipped[300];  /* distinct shapes left out ("'text' is not supported; the object is skipped") */
} child_state;

/* Appends `key` to the '|'-separated list unless it is there already. */
static void list_add(char *list, size_t size, const char *key)
{
    size_t len = strlen(list), n = strlen(key);
    for (const char *s = list; (s = strstr(s, key)) != NULL; s += n)
        if ((s == list || s[-1] == '|') && (s[n] == 0 || s[n] == '|'))
            return;
    if (len + n + 2 < size)
        snprintf(list + len, size - len, "%s%s", len ? "|" : "", key);
}

static void on_diag(const vbnl_sdl_diag *d, void *user)
{
    child_state *c = user;
    if (d->severity != VBNL_SDL_WARNING)
        return;
    c->warnings++;
    /* a shape left out: "'lathe' is not supported; the object is skipped" or
     * "height_field: 'pot' images are not read ...; the object is skipped" */
    const char *tail = strstr(d->message, "' is not supported; the object is skipped");
    const char *colon = strchr(d->message, ':');
    char shape[64] = "";
    if (d->message[0] == '\'' && tail && tail - d->message < 64)
        snprintf(shape, sizeof shape, "%.*s", (int)(tail - d->message - 1), d->message + 1);
    else if (strstr(d->message, "the object is skipped") && colon && colon - d->message < 32)
        snprintf(shape, sizeof shape, "%.*s", (int)(colon - d->message), d->message);
    if (shape[0])
        list_add(c->skipped, sizeof c->skipped, shape);
    if (!strstr(d->message, "not supported") && !strstr(d->message, "ignored") && !strstr(d->message, "skipped"))
        return;
    char key[200];
    snprintf(key, sizeof key, "%s", d->message);
    for (char *k = key; *k; ++k)
        if (*k == '|')
            *k = '/';
    list_add(c->features, sizeof c->features, key);
}

/* Child: load and write "status\twarnings\tskipped shapes\tmessage\n" to fd (message: the error,
 * or for scenes with warnings the unsupported features). */
static void child(const char *path, int fd)
{
    vbnl_error err = { 0 };
    char out[1200];
    vbnl_context *ctx = NULL;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 1;
    child_state cs = {0, "", ""};
    if (vbnl_context_create(&cd, &ctx, &err) != VBNL_OK) {
        snprintf(out, sizeof out, "error\t0\t\t%.700s\n", err.message);
    } else {
        vbnl_pov_options o;
        vbnl_pov_options_init(&o);
        o.width = 320;
        o.height = 240;
        o.no_commit = 1;
        o.diag = on_diag;
        o.diag_user = &cs;
        vbnl_pov_scene *s = NULL;
        vbnl_result r = vbnl_pov_load_file(ctx, path, &o, &s, &err);
        if (r == VBNL_OK)
            snprintf(out, sizeof out, "%s\t%d\t%s\t%s\n", cs.warnings ? "warnings" : "clean", cs.warnings, cs.skipped,
                     cs.features);
        else
            snprintf(out, sizeof out, "error\t%d\t%s\t%.600s\n", cs.warnings, cs.skipped, err.message);
        vbnl_pov_scene_destroy(s);
        vbnl_context_destroy(ctx);
    }
    for (char *c = out; *c; c++)
        if (*c == '\n' && c[1])
            *c = ' ';
    ssize_t wr = write(fd, out, strlen(out));
    (void)wr;
}

/* "file:12:3: undeclared identifier 'Foo'" -> "undeclared identifier '…'" */
static void normalize(const char *msg, char *out, size_t n)
{
    const char *m = msg;
    /* skip "path:line:col: " */
    const char *c = strstr(msg, ": ");
    if (c && c - msg < 400) {
        const char *q = c;
        while (q > msg && q[-1] >= '0' && q[-1] <= '9')
            q--;
        if (q > msg && q[-1] == ':')
            m = c + 2;
    }
    size_t o = 0;
    bool inq = false;
    for (; *m && o + 4 < n; m++) {
        if (*m == '\'' || *m == '"') {
            if (!inq) {
                out[o++] = *m;
                out[o++] = '.';
                out[o++] = '.';
                inq = true;
            } else {
                out[o++] = *m;
                inq = false;
            }
            continue;
        }
        if (!inq)
            out[o++] = *m;
    }
    out[o] = 0;
}

typedef struct count {
    char msg[300];
    int n;
    const char *example;
} count;

static int cmp_count(const void *a, const void *b)
{
    return ((const count *)b)->n - ((const count *)a)->n;
}

int main(int argc, char **argv)
{
    double check = 0.0;
    int timeout = 20, verbose = 0;
    const char *dir = "/usr/share/povray-3.7/scenes";
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-t") == 0 && i + 1 < argc)
            timeout = atoi(argv[++i]);
        else if (strcmp(argv[i], "-v") == 0)
            verbose = 1;
        else if (strcmp(argv[i], "--check") == 0 && i + 1 < argc)
            check = atof(argv[++i]);
        else
            dir = argv[i];
    }
    collect(dir);
    if (nentries == 0) {
        fprintf(stderr, "no .pov files under %s (apt-get install povray-examples)\n", dir);
        return check > 0.0 ? 77 : 0;
    }
    qsort(entries, nentries, sizeof *entries, cmp_entry);
    int clean = 0, warn = 0, errors = 0, timeouts = 0, crashes = 0;
    for (size_t i = 0; i < nentries; i++) {
        entry *e = &entries[i];
        int fds[2];
        if (pipe(fds) != 0)
            return 1;
        struct timespec ts0, ts1;
        clock_gettime(CLOCK_MONOTONIC, &ts0);
        pid_t pid = fork();
        if (pid == 0) {
            close(fds[0]);
            /* the limit is processor time, so that a loaded machine does not fail a scene; the
             * wall-clock alarm at four times it catches a child that blocks */
            struct rlimit rl = {(rlim_t)timeout, (rlim_t)timeout + 1};
            setrlimit(RLIMIT_CPU, &rl);
            alarm(4u * (unsigned)timeout);
            child(e->path, fds[1]);
            _exit(0);
        }
        close(fds[1]);
        char buf[1400];
        size_t got = 0;
        ssize_t r;
        while ((r = read(fds[0], buf + got, sizeof buf - 1 - got)) > 0)
            got += (size_t)r;
        buf[got] = 0;
        close(fds[0]);
        int st = 0;
        waitpid(pid, &st, 0);
        clock_gettime(CLOCK_MONOTONIC, &ts1);
        e->seconds = (double)(ts1.tv_sec - ts0.tv_sec) + 1e-9 * (double)(ts1.tv_nsec - ts0.tv_nsec);
        if (WIFSIGNALED(st) && (WTERMSIG(st) == SIGALRM || WTERMSIG(st) == SIGXCPU)) {
            snprintf(e->status, sizeof e->status, "timeout");
            int cpu = WTERMSIG(st) == SIGXCPU;
            snprintf(e->message, sizeof e->message, "time limit of %d s exceeded (%s)", cpu ? timeout : 4 * timeout,
                     cpu ? "processor time" : "wall clock");
            timeouts++;
        } else if (!WIFEXITED(st) || got == 0) {
            snprintf(e->status, sizeof e->status, "crash");
            snprintf(e->message, sizeof e->message, "child died (status %d)", st);
            crashes++;
        } else {
            char *t1 = strchr(buf, '\t'), *t2 = t1 ? strchr(t1 + 1, '\t') : NULL;
            char *t3 = t2 ? strchr(t2 + 1, '\t') : NULL;
            if (t1) *t1 = 0;
            if (t2) *t2 = 0;
            if (t3) *t3 = 0;
            snprintf(e->status, sizeof e->status, "%.15s", buf);
            e->warnings = t1 ? atoi(t1 + 1) : 0;
            if (t2)
                snprintf(e->skipped, sizeof e->skipped, "%s", t2 + 1);
            if (t3) {
                char *nl = strchr(t3 + 1, '\n');
                if (nl)
                    *nl = 0;
                snprintf(e->message, sizeof e->message, "%s", t3 + 1);
            }
            if (strcmp(e->status, "clean") == 0) clean++;
            else if (strcmp(e->status, "warnings") == 0) warn++;
            else errors++;
        }
        if (verbose)
            printf("%-9s %3d %6.2fs  %s  %s%s%s%s\n", e->status, e->warnings, e->seconds, e->path, e->skipped[0] ? "[skipped: " : "",
                   e->skipped[0] ? e->skipped : "", e->skipped[0] ? "] " : "", e->message);
    }
    size_t n = nentries;
    printf("\nScene parser corpus (language + object layers): %zu scenes under %s (limit %d s of processor time each)\n\n", n, dir, timeout);
    printf("  %-22s %5s %7s\n", "result", "files", "share");
    printf("  %-22s %5d %6.1f%%\n", "parsed clean", clean, 100.0 * clean / n);
    printf("  %-22s %5d %6.1f%%\n", "parsed with warnings", warn, 100.0 * warn / n);
    printf("  %-22s %5d %6.1f%%\n", "error", errors, 100.0 * errors / n);
    printf("  %-22s %5d %6.1f%%\n", "timeout", timeouts, 100.0 * timeouts / n);
    printf("  %-22s %5d %6.1f%%\n", "crash", crashes, 100.0 * crashes / n);
    count *counts = calloc(n, sizeof *counts);
    size_t nc = 0;
    for (size_t i = 0; i < n && counts; i++) {
        entry *e = &entries[i];
        if (strcmp(e->status, "error") && strcmp(e->status, "timeout") && strcmp(e->status, "crash"))
            continue;
        char key[300];
        normalize(e->message, key, sizeof key);
        size_t k;
        for (k = 0; k < nc; k++)
            if (strcmp(counts[k].msg, key) == 0)
                break;
        if (k == nc) {
            snprintf(counts[nc].msg, sizeof counts[nc].msg, "%s", key);
            counts[nc].example = e->message;
            nc++;
        }
        counts[k].n++;
    }
    if (nc) {
        qsort(counts, nc, sizeof *counts, cmp_count);
        printf("\nTop error messages:\n");
        for (size_t k = 0; k < nc && k < 20; k++)
            printf("  %4d  %s\n        e.g. %.200s\n", counts[k].n, counts[k].msg, counts[k].example);
    }
    free(counts);
    /* unsupported features: how many scenes report each */
    counts = calloc(64 * n + 1, sizeof *counts);
    nc = 0;
    for (size_t i = 0; i < n && counts; i++) {
        entry *e = &entries[i];
        if (strcmp(e->status, "warnings"))
            continue;
        char list[600];
        snprintf(list, sizeof list, "%s", e->message);
        for (char *tok = strtok(list, "|"); tok; tok = strtok(NULL, "|")) {
            size_t k;
            for (k = 0; k < nc; k++)
                if (strcmp(counts[k].msg, tok) == 0)
                    break;
            if (k == nc) {
                snprintf(counts[nc].msg, sizeof counts[nc].msg, "%s", tok);
                counts[nc].example = e->path;
                nc++;
            }
            counts[k].n++;
        }
    }
    if (nc) {
        qsort(counts, nc, sizeof *counts, cmp_count);
        printf("\nTop unsupported features (scenes reporting each):\n");
        for (size_t k = 0; k < nc && k < 20; k++)
            printf("  %4d  %s\n", counts[k].n, counts[k].msg);
    }
    free(counts);
    /* shapes left out: how many scenes (loaded with or without error) lose each */
    counts = calloc(32 * n + 1, sizeof *counts);
    nc = 0;
    for (size_t i = 0; i < n && counts; i++) {
        char list[300];
        snprintf(list, sizeof list, "%s", entries[i].skipped);
        for (char *tok = strtok(list, "|"); tok; tok = strtok(NULL, "|")) {
            size_t k;
            for (k = 0; k < nc; k++)
                if (strcmp(counts[k].msg, tok) == 0)
                    break;
            if (k == nc) {
                snprintf(counts[nc].msg, sizeof counts[nc].msg, "%s", tok);
                counts[nc].example = entries[i].path;
                nc++;
            }
            counts[k].n++;
        }
    }
    printf("\nObjects skipped (scenes losing each shape): %s\n", nc ? "" : "none");
    if (nc) {
        qsort(counts, nc, sizeof *counts, cmp_count);
        for (size_t k = 0; k < nc; k++)
            printf("  %4d  %-16s e.g. %s\n", counts[k].n, counts[k].msg, counts[k].example);
    }
    free(counts);
    for (size_t i = 0; i < n; i++)
        free(entries[i].path);
    free(entries);
    if (check > 0.0) {
        double ok = 100.0 * (clean + warn) / (double)n;
        if (crashes || timeouts || ok < check) {
            printf("# FAILED: %.1f%% parsed without error (need %.0f%%), %d crashes, %d timeouts\n", ok, check,
                   crashes, timeouts);
            return 1;
        }
    }
    return 0;
}
