/* The atomic writer on what an output path can name besides a regular file: a device is
 * written into and stays a device, a FIFO is written into and stays a FIFO, a symbolic link is
 * written through to its target (the link stays), a directory is refused with one line; and
 * a full disk (a file-size limit, which fails write() as a full disk does) fails the commit
 * with one line and leaves the previous file as it was; what a kill leaves (temporaries, a
 * log past the checkpoint) is cleaned up. */
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>

#include "check.h"
#include "gaussvid/core/core.h"

static char dir[4096];

/* path = dir/name */
static const char *at(const char *name)
{
    static char paths[4][4200];
    static int next;
    char *p = paths[next++ % 4];
    snprintf(p, sizeof paths[0], "%s/%s", dir, name);
    return p;
}

static int has_text(const char *path, const char *text)
{
    char *data;
    size_t size;
    if (gv_read_file(path, &data, &size) != 0) return 0;
    int same = strcmp(data, text) == 0;
    free(data);
    return same;
}

static int write_plain(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f) return -1;
    fputs(text, f);
    return fclose(f);
}

/* Files in folder whose names contain ".tmp." (temporaries left behind). */
static int temporaries_in(const char *folder)
{
    DIR *d = opendir(folder);
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += strstr(e->d_name, ".tmp.") != NULL;
    closedir(d);
    return n;
}

static int is_link(const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0 && S_ISLNK(st.st_mode);
}

static void test_device(void)
{
    /* The report's reproduction first, on a node made by mknod (root only): it must stay a
     * device. Only then /dev/null itself, so a regression cannot replace the system's. */
    struct stat st;
    int node_kept = 1;
    if (geteuid() == 0 && mknod(at("null"), S_IFCHR | 0666, makedev(1, 3)) == 0) {
        CHECK(gv_write_text_atomic(at("null"), "not a regular file") == 0);
        node_kept = stat(at("null"), &st) == 0 && S_ISCHR(st.st_mode) && st.st_rdev == makedev(1, 3);
        CHECK(node_kept);
        /* and through a link to it */
        CHECK(symlink("null", at("null-link")) == 0);
        CHECK(gv_write_text_atomic(at("null-link"), "through a link") == 0);
        CHECK(stat(at("null"), &st) == 0 && S_ISCHR(st.st_mode) && is_link(at("null-link")));
    }
    if (!node_kept) return;
    CHECK(gv_write_text_atomic("/dev/null", "into the null device") == 0);
    CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) == 1 && minor(st.st_rdev) == 3);
    CHECK(temporaries_in("/dev") == 0);
    gv_atomic_file af;
    CHECK(gv_atomic_open(&af, "/dev/null") == 0 && af.direct);
    for (int i = 0; i < 100000; i++) fputs("0123456789", af.f); /* a megabyte, several flushes */
    CHECK(gv_atomic_commit(&af) == 0);
    CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode));
}

static void test_fifo(void)
{
    const char *fifo = at("fifo");
    CHECK(mkfifo(fifo, 0600) == 0);
    int reader = open(fifo, O_RDONLY | O_NONBLOCK); /* so the writer's open does not wait */
    CHECK(reader >= 0);
    CHECK(gv_write_text_atomic(fifo, "through the fifo") == 0);
    char got[64] = "";
    ssize_t n = read(reader, got, sizeof got - 1);
    CHECK(n == 17 && memcmp(got, "through the fifo\n", 17) == 0);
    close(reader);
    struct stat st;
    CHECK(lstat(fifo, &st) == 0 && S_ISFIFO(st.st_mode));
    CHECK(temporaries_in(dir) == 0);
}

static void test_directory(void)
{
    const char *folder = at("folder");
    CHECK(mkdir(folder, 0755) == 0);
    CHECK_FAILS_WITH(gv_write_text_atomic(folder, "x"), "is a directory");
    CHECK(strchr(gv_last_error(), '\n') == NULL);
    gv_atomic_file af;
    CHECK_FAILS_WITH(gv_atomic_open(&af, folder), folder);
    CHECK(gv_dir_exists(folder) && temporaries_in(folder) == 0 && temporaries_in(dir) == 0);
    /* a link to a directory is refused the same way */
    CHECK(symlink("folder", at("folder-link")) == 0);
    CHECK_FAILS_WITH(gv_write_text_atomic(at("folder-link"), "x"), "is a directory");
    CHECK(is_link(at("folder-link")) && gv_dir_exists(folder));
}

static void test_symlinks(void)
{
    /* Same folder, relative target: the target is replaced, its permissions kept. */
    CHECK(write_plain(at("real.txt"), "old\n") == 0 && chmod(at("real.txt"), 0640) == 0);
    CHECK(symlink("real.txt", at("link.txt")) == 0);
    CHECK(gv_write_text_atomic(at("link.txt"), "new") == 0);
    CHECK(is_link(at("link.txt")) && has_text(at("real.txt"), "new\n"));
    struct stat st;
    CHECK(stat(at("real.txt"), &st) == 0 && (st.st_mode & 0777) == 0640);

    /* Another folder: the temporary is made beside the target, none is left anywhere. */
    CHECK(mkdir(at("a"), 0755) == 0 && mkdir(at("b"), 0755) == 0);
    CHECK(write_plain(at("b/target.txt"), "old\n") == 0);
    CHECK(symlink("../b/target.txt", at("a/link.txt")) == 0);
    gv_atomic_file af;
    CHECK(gv_atomic_open(&af, at("a/link.txt")) == 0 && !af.direct);
    CHECK(strstr(af.tmp_path, "/b/target.txt.tmp.") != NULL);
    fputs("across\n", af.f);
    CHECK(has_text(at("b/target.txt"), "old\n")); /* not visible before the commit */
    CHECK(gv_atomic_commit(&af) == 0);
    CHECK(is_link(at("a/link.txt")) && has_text(at("b/target.txt"), "across\n"));
    CHECK(temporaries_in(at("a")) == 0 && temporaries_in(at("b")) == 0);

    /* An absolute link, and a chain of two. */
    CHECK(symlink(at("b/target.txt"), at("abs.txt")) == 0);
    CHECK(symlink("abs.txt", at("chain.txt")) == 0);
    CHECK(gv_write_text_atomic(at("chain.txt"), "chained") == 0);
    CHECK(is_link(at("chain.txt")) && is_link(at("abs.txt")) && has_text(at("b/target.txt"), "chained\n"));

    /* A dangling link names the file to create. */
    CHECK(symlink("b/created.txt", at("dangling.txt")) == 0);
    CHECK(gv_write_text_atomic(at("dangling.txt"), "created") == 0);
    CHECK(is_link(at("dangling.txt")) && has_text(at("b/created.txt"), "created\n"));

    /* An aborted write through a link leaves the target as it was. */
    CHECK(gv_atomic_open(&af, at("link.txt")) == 0);
    fputs("never", af.f);
    gv_atomic_abort(&af);
    CHECK(has_text(at("real.txt"), "new\n") && temporaries_in(dir) == 0);

    /* A loop is refused with one line. */
    CHECK(symlink("loop2", at("loop1")) == 0 && symlink("loop1", at("loop2")) == 0);
    CHECK_FAILS_WITH(gv_write_text_atomic(at("loop1"), "x"), "symbolic links");
    CHECK(is_link(at("loop1")) && is_link(at("loop2")));
}

static void test_regular(void)
{
    /* A new file gets the usual permissions (0666 less the umask), not mkstemp's 0600. */
    mode_t mask = umask(022);
    CHECK(gv_write_text_atomic(at("fresh.txt"), "fresh") == 0);
    struct stat st;
    CHECK(stat(at("fresh.txt"), &st) == 0 && (st.st_mode & 0777) == 0644);
    umask(mask);
    /* A folder that does not exist: one line naming the file. */
    CHECK_FAILS_WITH(gv_write_text_atomic(at("missing/out.txt"), "x"), "missing/out.txt");
}

/* A file-size limit makes write() fail past `bytes` (EFBIG; SIGXFSZ ignored), as a disk with
 * that much room left fails with ENOSPC: the one difference is the message's reason. */
static void test_disk_full(void)
{
    const char *path = at("full.txt");
    CHECK(write_plain(path, "previous\n") == 0);
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit saved, small = {8192, 8192};
    CHECK(getrlimit(RLIMIT_FSIZE, &saved) == 0);
    small.rlim_max = saved.rlim_max;
    CHECK(setrlimit(RLIMIT_FSIZE, &small) == 0);
    gv_atomic_file af;
    CHECK(gv_atomic_open(&af, path) == 0);
    for (int i = 0; i < 10000; i++) fputs("0123456789", af.f); /* 100 kB: fails mid-way */
    CHECK_FAILS_WITH(gv_atomic_commit(&af), "full.txt: write error: File too large");
    CHECK(strchr(gv_last_error(), '\n') == NULL);
    /* Just over the limit: the last bytes fail only when the commit flushes them. */
    CHECK(gv_atomic_open(&af, path) == 0);
    for (int i = 0; i < 900; i++) fputs("0123456789", af.f);
    CHECK_FAILS_WITH(gv_atomic_commit(&af), "full.txt");
    /* A device is not limited by the file size: /dev/null still takes it. */
    CHECK(gv_atomic_open(&af, "/dev/null") == 0);
    for (int i = 0; i < 10000; i++) fputs("0123456789", af.f);
    CHECK(gv_atomic_commit(&af) == 0);
    CHECK(setrlimit(RLIMIT_FSIZE, &saved) == 0);
    signal(SIGXFSZ, SIG_DFL);
    CHECK(has_text(path, "previous\n") && temporaries_in(dir) == 0);
}

/* What a killed writer leaves (NAME.tmp.PID.K, or NAME.tmp.PID as before) is swept when
 * its process is gone; a live process's temporaries and other files stay. */
static void test_sweep(void)
{
    CHECK(mkdir(at("sweep"), 0755) == 0);
    pid_t child = fork();
    if (child == 0) _exit(0);
    waitpid(child, NULL, 0); /* a pid that is gone */
    char name[256];
    snprintf(name, sizeof name, "sweep/a.json.tmp.%ld.3", (long)child);
    CHECK(write_plain(at(name), "partial") == 0);
    snprintf(name, sizeof name, "sweep/b.ply.tmp.%ld", (long)child);
    CHECK(write_plain(at(name), "partial") == 0);
    snprintf(name, sizeof name, "sweep/c.safetensors.tmp.%ld.0", (long)getppid()); /* alive */
    CHECK(write_plain(at(name), "in progress") == 0);
    CHECK(write_plain(at("sweep/notes.tmp.txt"), "not ours") == 0);
    CHECK(write_plain(at("sweep/d.tmp.12x"), "not ours") == 0);
    CHECK(gv_atomic_sweep(at("sweep"), "b.") == 1);
    CHECK(gv_atomic_sweep(at("sweep"), NULL) == 1);
    CHECK(temporaries_in(at("sweep")) == 3); /* the live one and the two that are not ours */
    CHECK(gv_file_exists(at(name)) && gv_file_exists(at("sweep/d.tmp.12x")));
}

/* A log rewound to the checkpoint's step: the header and rows up to it stay, later rows and
 * a row cut short by a kill go; nothing to do leaves the file alone; no file is fine. */
static void test_step_log_rewind(void)
{
    const char *log = at("train.tsv");
    CHECK(write_plain(log, "step\tloss\n1\t0.5\n2\t0.4\n3\t0.3\n4\t0.2\n5\t0.") == 0);
    CHECK(gv_step_log_rewind(log, 2) == 0 && has_text(log, "step\tloss\n1\t0.5\n2\t0.4\n"));
    CHECK(gv_step_log_rewind(log, 9) == 0 && has_text(log, "step\tloss\n1\t0.5\n2\t0.4\n"));
    CHECK(write_plain(log, "step\tloss\n1\t0.5\n2\t0.") == 0);
    CHECK(gv_step_log_rewind(log, 2) == 0 && has_text(log, "step\tloss\n1\t0.5\n"));
    CHECK(gv_step_log_rewind(at("no-such.tsv"), 2) == 0 && !gv_file_exists(at("no-such.tsv")));
    CHECK(temporaries_in(dir) == 0);
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", check_tmp_dir());
    test_device();
    test_fifo();
    test_directory();
    test_symlinks();
    test_regular();
    test_disk_full();
    test_sweep();
    test_step_log_rewind();
    return check_summary();
}
