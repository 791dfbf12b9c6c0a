/* ini_touch BOARD.ini: the [touch] name and device as hapticd's parser sees
 * them (the same libinih, the last value wins as in board.c), one
 * "key<TAB>value" line each, then "error<TAB>LINE" when inih reports a
 * syntax error. tests/package/test-touch-rule holds hapticd-touch-rule's own
 * reading of each sample board against this one. */
#include <ini.h>

#include <stdio.h>
#include <string.h>

struct touch {
    char name[512], device[512];
    int has_name, has_device;
};

static int handler(void *user, const char *section, const char *key, const char *value)
{
    struct touch *t = user;
    if (strcmp(section, "touch") != 0)
        return 1;
    if (!strcmp(key, "name")) {
        snprintf(t->name, sizeof t->name, "%s", value);
        t->has_name = 1;
    } else if (!strcmp(key, "device")) {
        snprintf(t->device, sizeof t->device, "%s", value);
        t->has_device = 1;
    }
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: ini_touch BOARD.ini\n");
        return 2;
    }
    struct touch t = {0};
    int rc = ini_parse(argv[1], handler, &t);
    if (rc < 0) {
        fprintf(stderr, "ini_touch: %s: cannot read\n", argv[1]);
        return 2;
    }
    if (t.has_name)
        printf("name\t%s\n", t.name);
    if (t.has_device)
        printf("device\t%s\n", t.device);
    if (rc > 0)
        printf("error\t%d\n", rc);
    return 0;
}
