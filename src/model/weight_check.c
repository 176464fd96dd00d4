/* Checking safetensors files against the tensors a model config implies: what is missing,
 * unexpected, mis-shaped or duplicated, so that a loader (and `gaussvid model inspect`) can
 * say exactly why a set of files does not load. */
#include "gaussvid/model/weight_names.h"
#include "gaussvid/core/core.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { LISTED_IN_MESSAGE = 3 };

typedef struct {
    gv_weight_issue *items;
    int n, cap;
} issue_list;

static gv_weight_issue *push(issue_list *list)
{
    if (list->n == list->cap) {
        int cap = list->cap ? 2 * list->cap : 16;
        gv_weight_issue *items = realloc(list->items, (size_t)cap * sizeof *items);
        if (!items) return NULL;
        list->items = items;
        list->cap = cap;
    }
    gv_weight_issue *issue = &list->items[list->n++];
    memset(issue, 0, sizeof *issue);
    return issue;
}

static int is_float_dtype(gv_st_dtype d)
{
    return d == GV_ST_F32 || d == GV_ST_F16 || d == GV_ST_BF16 || d == GV_ST_F64;
}

static int same_shape(const gv_weight_spec *w, const gv_st_tensor *t)
{
    if (w->rank != t->rank) return 0;
    for (int k = 0; k < w->rank; k++)
        if (w->shape[k] != t->shape[k]) return 0;
    return 1;
}

/* Checks one tensor of a file: returns -1 when out of memory. */
static int check_tensor(const gv_weight_list *l, const gv_st_file *files, int f, const gv_st_tensor *t,
                        issue_list *unexpected, issue_list *mismatched, issue_list *duplicate)
{
    for (int g = 0; g < f; g++) {
        if (!gv_st_find(&files[g], t->name)) continue;
        gv_weight_issue *issue = push(duplicate);
        if (!issue) return -1;
        issue->name = t->name;
        issue->file = files[f].path;
        snprintf(issue->detail, sizeof issue->detail, "also in %s", files[g].path);
        return 0;
    }
    const gv_weight_spec *w = gv_weight_list_find(l, t->name);
    if (!w) {
        gv_weight_issue *issue = push(unexpected);
        if (!issue) return -1;
        issue->name = t->name;
        issue->file = files[f].path;
        return 0;
    }
    int shape_ok = same_shape(w, t), dtype_ok = is_float_dtype(t->dtype);
    if (shape_ok && dtype_ok) return 0;
    gv_weight_issue *issue = push(mismatched);
    if (!issue) return -1;
    issue->name = w->name;
    issue->file = files[f].path;
    char want[96], got[96];
    gv_st_shape_str(want, sizeof want, w->shape, w->rank);
    gv_st_shape_str(got, sizeof got, t->shape, t->rank);
    if (!shape_ok) snprintf(issue->detail, sizeof issue->detail, "expected %s, found %s", want, got);
    else snprintf(issue->detail, sizeof issue->detail, "dtype %s, expected F32, F16, BF16 or F64", gv_st_dtype_name(t->dtype));
    return 0;
}

int gv_weights_check(const gv_weight_list *l, unsigned parts, const gv_st_file *files, int n_files,
                     gv_weight_report *r)
{
    memset(r, 0, sizeof *r);
    issue_list missing = {0}, unexpected = {0}, mismatched = {0}, duplicate = {0};
    int rc = 0;
    for (int f = 0; f < n_files && !rc; f++) {
        r->n_found += files[f].n_tensors;
        for (int i = 0; i < files[f].n_tensors && !rc; i++)
            rc = check_tensor(l, files, f, &files[f].tensors[i], &unexpected, &mismatched, &duplicate);
    }
    for (int i = 0; i < l->n && !rc; i++) {
        const gv_weight_spec *w = &l->items[i];
        if (!(gv_module_part(w->module) & parts)) continue;
        r->n_expected++;
        int found = 0;
        for (int f = 0; f < n_files && !found; f++) found = gv_st_find(&files[f], w->name) != NULL;
        if (found) continue;
        gv_weight_issue *issue = push(&missing);
        if (!issue) { rc = -1; break; }
        issue->name = w->name;
        gv_st_shape_str(issue->detail, sizeof issue->detail, w->shape, w->rank);
    }
    r->missing = missing.items, r->n_missing = missing.n;
    r->unexpected = unexpected.items, r->n_unexpected = unexpected.n;
    r->mismatched = mismatched.items, r->n_mismatched = mismatched.n;
    r->duplicate = duplicate.items, r->n_duplicate = duplicate.n;
    if (rc) {
        gv_weight_report_free(r);
        return gv_fail("out of memory while checking weights");
    }
    return 0;
}

int gv_weight_report_ok(const gv_weight_report *r)
{
    return r->n_missing == 0 && r->n_unexpected == 0 && r->n_mismatched == 0 && r->n_duplicate == 0;
}

/* Appends "N kind (a, b, c, ...)" to out. */
static void append_kind(char *out, size_t size, const char *kind, const gv_weight_issue *items, int n, int with_detail)
{
    if (n == 0) return;
    size_t len = strlen(out);
    snprintf(out + len, size - len, "%s%d %s (", len ? "; " : "", n, kind);
    for (int i = 0; i < n && i < LISTED_IN_MESSAGE; i++) {
        len = strlen(out);
        snprintf(out + len, size - len, "%s%s%s%s", i ? ", " : "", items[i].name, with_detail ? " " : "",
                 with_detail ? items[i].detail : "");
    }
    len = strlen(out);
    snprintf(out + len, size - len, "%s)", n > LISTED_IN_MESSAGE ? ", ..." : "");
}

int gv_weight_report_fail(const gv_weight_report *r, const char *what)
{
    if (gv_weight_report_ok(r)) return 0;
    char text[900] = "";
    append_kind(text, sizeof text, "missing", r->missing, r->n_missing, 0);
    append_kind(text, sizeof text, "unexpected", r->unexpected, r->n_unexpected, 0);
    append_kind(text, sizeof text, "mis-shaped", r->mismatched, r->n_mismatched, 1);
    append_kind(text, sizeof text, "duplicated", r->duplicate, r->n_duplicate, 1);
    return gv_fail("%s: the weights do not load: %s", what, text);
}

void gv_weight_report_free(gv_weight_report *r)
{
    free(r->missing);
    free(r->unexpected);
    free(r->mismatched);
    free(r->duplicate);
    memset(r, 0, sizeof *r);
}
