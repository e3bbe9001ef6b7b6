/* sphice: the program on top of the service layer. */
#include <stdio.h>
#include <string.h>

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "version") == 0) {
        printf("sphice %s (%s)\n", SPHICE_VERSION, SPHICE_GIT);
        return 0;
    }
    fprintf(stderr, "usage: sphice version\n");
    return 2;
}
