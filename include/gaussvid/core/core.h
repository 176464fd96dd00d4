/* Core services shared by every module: errors, logging, timing, progress bars, files
 * written atomically, command-line flags and a counter-based random number generator. */
#ifndef GAUSSVID_CORE_H
#define GAUSSVID_CORE_H

#include <stdint.h>
#include <stdio.h>
#include <stddef.h>

/* ---- Errors ---------------------------------------------------------------------------
 * Functions that can fail return 0 on success and -1 on failure, after recording one line
 * that names the input and what is wrong (SQLite style). The caller either handles it or
 * passes -1 up; the command line prints it. The message is per thread. */
int gv_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Prefixes the current message with "what: " (e.g. a file name) and returns -1. */
int gv_fail_context(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
const char *gv_last_error(void);
void gv_clear_error(void);
/* Prints "gaussvid: <last error>" on stderr and returns 1 (a command's failure exit code). */
int gv_report_failure(void);

/* ---- Logging ------------------------------------------------------------------------ */
enum { GV_LOG_QUIET = 0, GV_LOG_INFO = 1, GV_LOG_DEBUG = 2 };
void gv_log_set_level(int level);
int gv_log_level(void);
/* Informational line on stderr; silent under --quiet. */
void gv_info(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void gv_debug(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Warning line on stderr; always shown. */
void gv_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* ---- Time --------------------------------------------------------------------------- */
double gv_now(void); /* monotonic seconds */
/* CPU seconds of the whole process (all threads): on a shared machine the steadier measure
 * of work than the wall clock. */
double gv_cpu_now(void);

/* ---- Progress bar -------------------------------------------------------------------
 * On a terminal: one line redrawn in place with count, rate and ETA. Otherwise: a plain
 * line every few seconds. Nothing at all under --quiet. */
typedef struct {
    char label[96]; /* bench splat's run names reach about 60 characters */
    long total;
    long done;
    double start, last_draw;
    int on_terminal;
    int enabled;
} gv_progress;
void gv_progress_start(gv_progress *p, const char *label, long total);
/* Sets the count to `done`; `extra` (printf format, may be NULL) is shown after the bar. */
void gv_progress_update(gv_progress *p, long done, const char *extra, ...)
    __attribute__((format(printf, 3, 4)));
/* A log line (info level) in place of the bar, which is drawn again at the next update. */
void gv_progress_note(gv_progress *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void gv_progress_finish(gv_progress *p);
/* Mutes (1) or unmutes (0) the bars started on the calling thread, e.g. in workers that run
 * side by side, whose bars would overwrite one another. */
void gv_progress_mute_thread(int muted);

/* ---- Names (names.c): items found by their name ----------------------------------------
 * name_of(items, i) is the name of item i. An order lists the items' positions sorted by name;
 * with order NULL the items themselves are in that order. */
typedef const char *(*gv_name_of)(const void *items, int i);
/* Fills order[0..n) with the positions of the n items sorted by name; *repeat is a name that
 * appears twice (the caller says what that means), else NULL. Fails only on no memory. */
int gv_names_order(const void *items, int n, gv_name_of name_of, int *order, const char **repeat);
/* The item named name (bisection over the order; items are size bytes apart), or NULL. */
const void *gv_names_find(const void *items, size_t size, const int *order, int n, gv_name_of name_of,
                          const char *name);

/* ---- Files -------------------------------------------------------------------------- */
/* Reads a whole file; *data is NUL-terminated and must be freed. */
int gv_read_file(const char *path, char **data, size_t *size);
int gv_file_exists(const char *path);
int gv_dir_exists(const char *path);
/* Creates a directory and its parents (like mkdir -p). */
int gv_mkdirs(const char *path);
/* Joins two path parts with one '/' into out (size bytes); fails if it does not fit. */
int gv_path_join(char *out, size_t size, const char *a, const char *b);

/* Where the released models (the default restorer and its VAE) are looked for, first first
 * (src/core/models.c; docs/RECONSTRUCT.md "Where the models are found"):
 *   1. the folders of $GAUSSVID_MODELS (separated by ':', as PATH), when set;
 *   2. beside the program: its folder/../models (the source tree's build/gaussvid finds models/);
 *   3. installed: its folder/../share/gaussvid (`make install`: PREFIX/bin, PREFIX/share/gaussvid);
 *   4. the install prefix the program was built for (its share/gaussvid), when another.
 * Folders are made absolute (symbolic links and '..' resolved) when they exist; repeats are
 * listed once. */
#define GV_MODEL_DIRS_MAX 8
typedef struct {
    int count;
    int env_set;                  /* GAUSSVID_MODELS is set and not empty */
    char dir[GV_MODEL_DIRS_MAX][4096];
    char why[GV_MODEL_DIRS_MAX][32]; /* "GAUSSVID_MODELS", "beside the program", ... */
} gv_model_dirs;
void gv_model_dirs_list(gv_model_dirs *d);
/* The first of those folders holding the file `name` (a file name): its path into out, 1; 0
 * when none holds it. */
int gv_find_model(const char *name, char *out, size_t size);
/* "GAUSSVID_MODELS (not set), /repo/models (beside the program), ...": every place looked. */
void gv_model_dirs_describe(const gv_model_dirs *d, char *out, size_t size);

/* A file written under a temporary name in the same folder and renamed on commit, so that
 * a reader never sees it half-written (src/core/atomic_file.c). A symbolic link is followed:
 * the temporary goes beside the file it names, which is replaced and the link kept. An
 * existing device, FIFO or socket is written into directly (renaming over it would replace
 * the node); an existing directory is refused. */
typedef struct {
    FILE *f;
    int direct;                 /* writing straight into a device or FIFO: no rename */
    char path[4096];            /* as the caller named it, for messages */
    char target[4096];          /* path with its symbolic links followed */
    char tmp_path[4096 + 48];
} gv_atomic_file;
int gv_atomic_open(gv_atomic_file *af, const char *path);
/* Follows the symbolic links from path to the name they finally lead to, which need not
 * exist yet (a dangling link names the file to create). */
int gv_path_follow_links(const char *path, char *out, size_t size);
/* Flushes, fsyncs, closes and renames into place, then fsyncs the folder; on any write
 * error removes the temporary and leaves the previous file as it was. */
int gv_atomic_commit(gv_atomic_file *af);
void gv_atomic_abort(gv_atomic_file *af);
/* Removes from dir the temporaries (NAME.tmp.PID or NAME.tmp.PID.K) that a killed writer left,
 * those whose NAME starts with prefix (NULL: all); a live process's are kept. Returns how
 * many were removed. Long jobs call it on their output folders when they start. */
int gv_atomic_sweep(const char *dir, const char *prefix);
/* Removes the temporaries a killed writer left beside path: those of path itself and of the
 * files named after it (path.ckpt), in path's folder. */
int gv_atomic_sweep_beside(const char *path);
/* A log whose rows start with their step (a header line first): keeps the rows up to
 * last_step, drops the later ones and a last row cut short, so a run resumed from the
 * checkpoint of last_step appends each step once (src/core/step_log.c). */
int gv_step_log_rewind(const char *path, long last_step);
/* External programs (src/core/process.c): the path of a program (a name with a '/' as it is,
 * else the first executable on the PATH) into out; -1 when there is none (no message). */
int gv_find_program(const char *name, char *out, size_t size);
/* Runs argv[0] (a path) with argv, stdin from /dev/null, stdout and stderr appended to log;
 * returns its exit status (128 + signal when killed), or -1 with a message when it cannot start. */
int gv_run_logged(const char *const argv[], const char *log);
/* As gv_run_logged, and each line of the program's output (stdout and stderr; a carriage
 * return also ends a line; longer than 1023 bytes, cut) is given to on_line as it comes, for a
 * progress bar that follows the program. */
typedef void (*gv_line_fn)(const char *line, void *ctx);
int gv_run_watched(const char *const argv[], const char *log, gv_line_fn on_line, void *ctx);
/* Writes text and a final newline to path atomically (JSON documents, manifests). */
int gv_write_text_atomic(const char *path, const char *text);

/* ---- Command-line flags -------------------------------------------------------------
 * Every subcommand declares its flags in a table; the parser handles --help, --quiet and
 * --threads for all of them, so flags look and behave the same everywhere. */
typedef enum { GV_FLAG_BOOL, GV_FLAG_INT, GV_FLAG_DOUBLE, GV_FLAG_STRING, GV_FLAG_LIST } gv_flag_type;
/* The values of a list flag: "--name A B ..." takes every value up to the next option, and
 * "--name=A" one; the flag may be repeated and each value may be a comma-separated list. The
 * items point into argv (split in place at the commas). */
#define GV_FLAG_LIST_MAX 1024
typedef struct {
    const char *items[GV_FLAG_LIST_MAX];
    int n;
} gv_flag_list;
typedef struct {
    const char *name;   /* without the leading "--" */
    gv_flag_type type;
    void *value;        /* int*, int*, double*, const char**, gv_flag_list* */
    const char *meta;   /* value placeholder for the help, e.g. "DIR" */
    const char *help;
    int required;
} gv_flag;
typedef struct {
    const char *command;     /* e.g. "scene info" */
    const char *positional;  /* e.g. "DIR" or NULL when none is accepted */
    const char *summary;     /* one line */
    const char *details;     /* more text for --help, or NULL */
    const gv_flag *flags;
    int n_flags;
    int min_positional, max_positional;
} gv_command_spec;
enum { GV_ARGS_OK = 0, GV_ARGS_HELP = 1, GV_ARGS_ERROR = 2 };
/* Parses argv (argv[0] is the command name). Positional arguments are returned in
 * positional[0..*n_positional). Returns GV_ARGS_OK, GV_ARGS_HELP (help was printed) or
 * GV_ARGS_ERROR (a usage message was printed). */
int gv_args_parse(const gv_command_spec *spec, int argc, char **argv,
                  char **positional, int *n_positional);
/* Exit code of a command from the parser's result: 0 after help, 2 after a usage error. */
int gv_args_exit_code(int parse_result);
void gv_print_help(const gv_command_spec *spec, FILE *out);

/* ---- Random numbers ------------------------------------------------------------------
 * Philox-4x32-10 (Salmon et al. 2011): the n-th number of stream `seed` is a pure function
 * of (seed, n), so parallel loops give the same numbers whatever the thread count. */
typedef struct {
    uint64_t seed;
    uint64_t counter;   /* index of the next block of four 32-bit words */
    uint32_t block[4];
    int used;           /* words of block already consumed (4 = empty) */
} gv_rng;
void gv_philox4x32(uint64_t seed, uint64_t counter, uint32_t out[4]);
void gv_rng_init(gv_rng *r, uint64_t seed);
uint32_t gv_rng_u32(gv_rng *r);
double gv_rng_uniform(gv_rng *r);           /* in [0, 1) */
double gv_rng_normal(gv_rng *r);            /* standard normal (Box-Muller) */
/* Stateless forms: the value at position `index` of stream `seed`. */
double gv_uniform_at(uint64_t seed, uint64_t index);
double gv_normal_at(uint64_t seed, uint64_t index);

#endif
