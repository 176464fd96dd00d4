/* Items found by name (core.h, names.c): the order sorts, a repeat is named, the bisection
 * finds every item and nothing else, through an order or over items already sorted. */
#include <string.h>

#include "check.h"
#include "gaussvid/core/core.h"

typedef struct {
    int value;
    const char *name;
} item;

static const char *item_name(const void *items, int i)
{
    return ((const item *)items)[i].name;
}

int main(void)
{
    const item items[6] = {{0, "vace.b"}, {1, "a"}, {2, "blocks.10"}, {3, "blocks.2"}, {4, ""}, {5, "z"}};
    int order[6];
    const char *repeat = "x";
    CHECK(gv_names_order(items, 6, item_name, order, &repeat) == 0 && repeat == NULL);
    const int sorted[6] = {4, 1, 2, 3, 0, 5}; /* "", a, blocks.10, blocks.2, vace.b, z (strcmp) */
    CHECK(!memcmp(order, sorted, sizeof sorted));
    int found = 1;
    for (int i = 0; i < 6; i++) found &= gv_names_find(items, sizeof *items, order, 6, item_name, items[i].name) == &items[i];
    CHECK(found);
    const char *absent[] = {"b", "blocks", "blocks.1", "zz", "A", " "};
    for (int i = 0; i < 6; i++) CHECK(gv_names_find(items, sizeof *items, order, 6, item_name, absent[i]) == NULL);
    CHECK(gv_names_find(items, sizeof *items, order, 0, item_name, "a") == NULL);
    /* items already in name order: no order needed */
    const item in_order[3] = {{7, "alpha"}, {8, "beta"}, {9, "gamma"}};
    const item *hit = gv_names_find(in_order, sizeof *in_order, NULL, 3, item_name, "gamma");
    CHECK(hit && hit->value == 9);
    CHECK(gv_names_find(in_order, sizeof *in_order, NULL, 3, item_name, "delta") == NULL);
    /* a name twice is named, and the order is still sorted */
    const item twice[4] = {{0, "b"}, {1, "a"}, {2, "c"}, {3, "a"}};
    CHECK(gv_names_order(twice, 4, item_name, order, &repeat) == 0 && repeat && !strcmp(repeat, "a"));
    CHECK(!strcmp(twice[order[0]].name, "a") && !strcmp(twice[order[1]].name, "a") && order[3] == 2);
    return check_summary();
}
