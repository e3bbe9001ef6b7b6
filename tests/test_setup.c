/* The front door: README's set-up is two commands that work as typed on a
 * fresh Debian 12 machine, as root or as a user with sudo (issue 21, item
 * 13), and CI runs the README's test command.
 *
 * - README.md's "Set up" section lists exactly two commands, each a script
 *   of the repository, the second the one .ci/run calls;
 * - tools/install-deps.sh, run as root on a machine without sudo, calls
 *   apt-get itself (before: "sudo: not found", exit 127);
 * - run as a user without sudo it fails with one line saying what to do;
 * - run as a user with sudo it asks sudo for apt-get only.
 * The machine is simulated by a PATH holding only stand-ins for id, dpkg,
 * apt-get and sudo that record how they were called.
 */
#include "check.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *s = malloc(cap);
    size_t got;
    while (s && (got = fread(s + n, 1, cap - 1 - n, f)) > 0) {
        n += got;
        if (n + 1 >= cap) {
            char *t = realloc(s, cap *= 2);
            if (!t) {
                free(s);
                s = NULL;
            }
            s = t;
        }
    }
    fclose(f);
    if (s)
        s[n] = '\0';
    return s;
}

static void readme_commands(void)
{
    char *readme = slurp("README.md");
    char *ci = slurp(".ci/run");
    CHECK(readme && ci, "README.md and .ci/run readable from the repository root");
    if (!readme || !ci) {
        free(readme);
        free(ci);
        return;
    }
    char *sec = strstr(readme, "\n## Set up");
    CHECK(sec != NULL, "README.md has a '## Set up' section");
    char cmds[4][256];
    int n = 0;
    if (sec) {
        char *end = strstr(sec + 1, "\n## ");
        for (char *l = strchr(sec + 1, '\n'); l && (!end || l < end); l = strchr(l + 1, '\n')) {
            if (strncmp(l + 1, "    ", 4) != 0 || l[5] == ' ')
                continue;
            char *eol = strchr(l + 1, '\n');
            size_t len = eol ? (size_t)(eol - (l + 5)) : strlen(l + 5);
            char *hash = memchr(l + 5, '#', len);
            if (hash)
                len = (size_t)(hash - (l + 5));
            while (len && l[5 + len - 1] == ' ')
                len--;
            if (n < 4 && len < sizeof cmds[0]) {
                memcpy(cmds[n], l + 5, len);
                cmds[n][len] = '\0';
            }
            n++;
        }
    }
    CHECK(n == 2, "README's set-up lists %d commands, want 2 (one for the demo, one for the tests)", n);
    for (int i = 0; i < n && i < 2; i++) {
        char script[256];
        CHECK(sscanf(cmds[i], "sh %255s", script) == 1, "command '%s' runs a script with sh (no sudo, no make needed)", cmds[i]);
        struct stat sb;
        CHECK(stat(script, &sb) == 0 && S_ISREG(sb.st_mode), "'%s': %s is a file of the repository", cmds[i], script);
    }
    if (n >= 2)
        CHECK(strstr(ci, cmds[1]) != NULL, ".ci/run calls README's test command '%s'", cmds[1]);
    free(readme);
    free(ci);
}

/* A stand-in command in dir: a shell script body. */
static void stub(const char *dir, const char *name, const char *body)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f)
        return;
    fprintf(f, "#!/bin/sh\n%s\n", body);
    fclose(f);
    chmod(path, 0755);
}

/* Runs install-deps.sh on the simulated machine; returns its exit status
 * and the first line of its stderr in err. */
static int run_install(const char *dir, char *err, size_t errlen)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "cd '%s' && PATH='%s' %s tools/install-deps.sh >'%s/out' 2>'%s/err'",
             getenv("PWD") ? getenv("PWD") : ".", dir, "/bin/sh", dir, dir);
    int rc = system(cmd);
    rc = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
    char path[512];
    snprintf(path, sizeof path, "%s/err", dir);
    char *e = slurp(path);
    snprintf(err, errlen, "%s", e ? e : "");
    char *nl = strchr(err, '\n');
    if (nl)
        *nl = '\0';
    free(e);
    return rc;
}

static void install_deps(void)
{
    char dir[] = "/tmp/sphice-setup-XXXXXX";
    if (!mkdtemp(dir)) {
        CHECK(0, "mkdtemp");
        return;
    }
    char body[1024], err[512], path[600];
    /* every package missing; apt-get records how it was called */
    stub(dir, "dpkg", "exit 1");
    snprintf(body, sizeof body, "echo \"apt-get $*\" >> '%s/calls'", dir);
    stub(dir, "apt-get", body);

    /* root, no sudo on the machine */
    stub(dir, "id", "echo 0");
    int rc = run_install(dir, err, sizeof err);
    snprintf(path, sizeof path, "%s/calls", dir);
    char *calls = slurp(path);
    CHECK(rc == 0, "as root without sudo: exit %d (%s)", rc, err);
    CHECK(calls && strstr(calls, "apt-get update") && strstr(calls, "apt-get install"),
          "as root: apt-get update and install called directly (%s)", calls ? calls : "none");
    free(calls);
    unlink(path);

    /* a user, no sudo: one line, non-zero */
    stub(dir, "id", "echo 1000");
    rc = run_install(dir, err, sizeof err);
    CHECK(rc == 1, "as a user without sudo: exit %d, want 1", rc);
    CHECK(strstr(err, "sudo is not installed") && strstr(err, "as root"),
          "as a user without sudo: one line saying to run it as root (got '%s')", err);
    CHECK(access(path, F_OK) != 0, "as a user without sudo: apt-get not called");

    /* a user with sudo: sudo runs apt-get */
    snprintf(body, sizeof body, "echo \"sudo $*\" >> '%s/calls'", dir);
    stub(dir, "sudo", body);
    rc = run_install(dir, err, sizeof err);
    calls = slurp(path);
    CHECK(rc == 0, "as a user with sudo: exit %d (%s)", rc, err);
    CHECK(calls && strstr(calls, "sudo apt-get update") && strstr(calls, "apt-get install"),
          "as a user with sudo: apt-get through sudo (%s)", calls ? calls : "none");
    free(calls);

    char rm[600];
    snprintf(rm, sizeof rm, "rm -rf '%s'", dir);
    if (system(rm) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
}

int main(void)
{
    readme_commands();
    install_deps();
    return check_summary("test_setup");
}
