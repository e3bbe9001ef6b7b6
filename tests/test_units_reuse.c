/* The udunits2 database is read once per process (io/cf.h cf_units_create):
 * udunits2's ut_free_system leaves the prefix tables that ut_read_xml
 * builds allocated, so reading and freeing it once a cycle made the daemon
 * grow by kilobytes a cycle (issue 21's soak). Here: the heap in use
 * (glibc mallinfo2) after 40 more create/convert/free rounds is what it
 * was after the first, within 1 kB (the reading alone allocates hundreds of
 * kilobytes; its prefix tables several kilobytes a round). */
#include <malloc.h>
#include <math.h>

#include "check.h"
#include "io/cf.h"

static int round_trip(void)
{
    cf_units *u = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (cf_units_create(&u, &err) != 0) {
        CHECK(0, "create: %s", err.msg);
        return -1;
    }
    double a = NAN, b = NAN;
    int rc = cf_units_linear(u, "degC", "K", &a, &b);
    cf_units_free(u);
    /* T[K] = T[degC] + 273.15 (SI definition of the Celsius scale) */
    return rc == 0 && fabs(a - 1.0) < 1e-12 && fabs(b - 273.15) < 1e-9 ? 0 : -1;
}

int main(void)
{
    CHECK(round_trip() == 0, "first round: degC -> K is 1, 273.15");
    CHECK(round_trip() == 0, "second round");
    size_t before = mallinfo2().uordblks;
    int ok = 1;
    for (int k = 0; k < 40; k++)
        ok = ok && round_trip() == 0;
    size_t after = mallinfo2().uordblks;
    CHECK(ok, "40 rounds convert");
    long grew = (long)after - (long)before;
    CHECK(grew < 1024, "heap in use grew %ld bytes over 40 rounds (limit 1024)", grew);
    return check_summary("test_units_reuse");
}
