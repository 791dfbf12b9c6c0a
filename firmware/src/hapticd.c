/* hapticd: plays time-reversal haptic tables on touch triggers. */
#define _POSIX_C_SOURCE 200809L
#include <haptic_table.h>

#include <stdio.h>
#include <string.h>

static int check_table(const char *path)
{
    haptic_table t;
    haptic_table_error err;
    if (haptic_table_open(path, &t, &err) != 0) {
        fprintf(stderr, "hapticd: %s: %s\n", path, err.message);
        return 1;
    }
    haptic_table_print_summary(&t, path, stdout);
    haptic_table_close(&t);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--check") == 0)
        return check_table(argv[2]);
    fprintf(stderr, "usage: hapticd --check FILE.htab\n");
    return 2;
}
