/* Command-line flags from a declarative table; --help, --quiet and --threads are common to
 * every command. Flags are "--name value" or "--name=value"; booleans take no value; lists
 * take every value up to the next option. */
#include "gaussvid/core/core.h"

#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

static const char *type_meta(const gv_flag *f)
{
    if (f->meta) return f->meta;
    switch (f->type) {
    case GV_FLAG_INT: return "N";
    case GV_FLAG_DOUBLE: return "X";
    case GV_FLAG_STRING: return "S";
    default: return "";
    }
}

void gv_print_help(const gv_command_spec *spec, FILE *out)
{
    fprintf(out, "usage: gaussvid %s [options]%s%s\n\n%s\n", spec->command,
            spec->positional ? " " : "", spec->positional ? spec->positional : "", spec->summary);
    if (spec->details) fprintf(out, "\n%s\n", spec->details);
    fprintf(out, "\noptions:\n");
    for (int i = 0; i < spec->n_flags; i++) {
        const gv_flag *f = &spec->flags[i];
        char left[64];
        snprintf(left, sizeof left, "--%s%s%s", f->name, f->type == GV_FLAG_BOOL ? "" : " ",
                 type_meta(f));
        fprintf(out, "  %-24s %s%s\n", left, f->help, f->required ? " (required)" : "");
    }
    fprintf(out, "  %-24s %s\n", "--threads N", "worker threads (default: all cores)");
    fprintf(out, "  %-24s %s\n", "--quiet", "no progress bars or informational lines");
    fprintf(out, "  %-24s %s\n", "--help", "show this help");
}

static int usage_error(const gv_command_spec *spec, const char *fmt, const char *arg)
{
    fprintf(stderr, "gaussvid %s: ", spec->command);
    fprintf(stderr, fmt, arg);
    fprintf(stderr, " (see 'gaussvid %s --help')\n", spec->command);
    return GV_ARGS_ERROR;
}

/* Appends the comma-separated items of text (split in place) to a list flag. */
static int add_items(const gv_command_spec *spec, const gv_flag *f, char *text)
{
    gv_flag_list *l = f->value;
    for (char *item = strtok(text, ","); item; item = strtok(NULL, ",")) {
        if (l->n == GV_FLAG_LIST_MAX) return usage_error(spec, "too many values for --%s", f->name);
        l->items[l->n++] = item;
    }
    return GV_ARGS_OK;
}

static int set_value(const gv_command_spec *spec, const gv_flag *f, const char *text)
{
    char *end = NULL;
    errno = 0;
    switch (f->type) {
    case GV_FLAG_INT: {
        long v = strtol(text, &end, 10);
        if (errno || end == text || *end || v < -2147483647L || v > 2147483647L)
            return usage_error(spec, "--%s needs an integer", f->name);
        *(int *)f->value = (int)v;
        return GV_ARGS_OK;
    }
    case GV_FLAG_DOUBLE: {
        double v = strtod(text, &end);
        if (errno || end == text || *end || !isfinite(v))
            return usage_error(spec, "--%s needs a finite number", f->name);
        *(double *)f->value = v;
        return GV_ARGS_OK;
    }
    case GV_FLAG_STRING:
        *(const char **)f->value = text;
        return GV_ARGS_OK;
    default:
        return usage_error(spec, "--%s takes no value", f->name);
    }
}

int gv_args_parse(const gv_command_spec *spec, int argc, char **argv,
                  char **positional, int *n_positional)
{
    int count = 0;
    int seen[64] = {0};
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (strncmp(arg, "--", 2) != 0 || arg[2] == '\0') {
            if (count >= spec->max_positional)
                return usage_error(spec, "unexpected argument '%s'", arg);
            positional[count++] = argv[i];
            continue;
        }
        const char *name = arg + 2;
        const char *eq = strchr(name, '=');
        size_t name_len = eq ? (size_t)(eq - name) : strlen(name);
        if (name_len == 4 && !strncmp(name, "help", 4)) {
            gv_print_help(spec, stdout);
            return GV_ARGS_HELP;
        }
        if (name_len == 5 && !strncmp(name, "quiet", 5)) {
            gv_log_set_level(GV_LOG_QUIET);
            continue;
        }
        int is_threads = name_len == 7 && !strncmp(name, "threads", 7);
        const gv_flag *flag = NULL;
        int index = -1;
        for (int k = 0; k < spec->n_flags && !is_threads; k++) {
            if (strlen(spec->flags[k].name) == name_len &&
                !strncmp(spec->flags[k].name, name, name_len)) {
                flag = &spec->flags[k];
                index = k;
            }
        }
        if (!flag && !is_threads) return usage_error(spec, "unknown option '%s'", arg);
        const char *value = eq ? eq + 1 : NULL;
        if (flag && flag->type == GV_FLAG_BOOL) {
            if (value) return usage_error(spec, "%s takes no value", arg);
            *(int *)flag->value = 1;
            if (index < 64) seen[index] = 1;
            continue;
        }
        if (flag && flag->type == GV_FLAG_LIST) {
            int before = ((gv_flag_list *)flag->value)->n, rc = value ? add_items(spec, flag, (char *)value) : GV_ARGS_OK;
            while (rc == GV_ARGS_OK && !value && i + 1 < argc && strncmp(argv[i + 1], "--", 2))
                rc = add_items(spec, flag, argv[++i]);
            if (rc != GV_ARGS_OK) return rc;
            if (((gv_flag_list *)flag->value)->n == before) return usage_error(spec, "%s needs a value", arg);
            if (index < 64) seen[index] = 1;
            continue;
        }
        if (!value) {
            if (i + 1 >= argc) return usage_error(spec, "%s needs a value", arg);
            value = argv[++i];
        }
        if (is_threads) {
            char *end;
            long n = strtol(value, &end, 10);
            if (*end || n < 1 || n > 1024) return usage_error(spec, "--threads needs 1..1024%s", "");
            omp_set_num_threads((int)n);
            continue;
        }
        int rc = set_value(spec, flag, value);
        if (rc != GV_ARGS_OK) return rc;
        if (index < 64) seen[index] = 1;
    }
    for (int k = 0; k < spec->n_flags && k < 64; k++)
        if (spec->flags[k].required && !seen[k])
            return usage_error(spec, "--%s is required", spec->flags[k].name);
    if (count < spec->min_positional)
        return usage_error(spec, "missing %s", spec->positional ? spec->positional : "argument");
    if (n_positional) *n_positional = count;
    return GV_ARGS_OK;
}

int gv_args_exit_code(int parse_result)
{
    return parse_result == GV_ARGS_HELP ? 0 : 2;
}
