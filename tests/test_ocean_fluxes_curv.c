/* The fluxes file on a curvilinear ocean grid (issue 20 item 4,
 * OFX_GRID_CURV, docs/ocean-coupling.md):
 *  - conservation: on a grid rotated by 30 degrees and on a bent grid (a
 *    polar sector, i radial, j along the arc, like a ROMS grid following a
 *    coast) with land, the area integrals of heat, water, salt, shortwave,
 *    ice area and volume equal the particles' sums within 1e-10 relative,
 *    and the stress turned back from the file's i/j components with the
 *    file's angle equals the particles' stress; particles on land only
 *    reach the nearest water cell, particles off the grid are counted;
 *  - orientation: a uniform eastward stress on the 30-degree grid gives
 *    (cos 30, -sin 30) of its magnitude in every cell (ROMS's rule
 *    u_xi = u_E cos(angle) + v_N sin(angle), v_eta = v_N cos(angle) -
 *    u_E sin(angle)) within 1e-12, and angle = 30 degrees; on the bent
 *    grid angle = the polar angle of each cell's centre;
 *  - the stress is minus the water drag on the ice (steady free drift):
 *    the file's components turned back to the plane, times the cell
 *    areas, over the footprint equal -rho_w C_w |U_w - u| R(theta) (U_w - u)
 *    computed here within 1e-10;
 *  - grids the writer cannot orient (left-handed corners, a skewed grid)
 *    are refused with one line;
 *  - the reader (io/ocean_grid.h): a NEMO/XIOS-style file (nav_lon/nav_lat
 *    with bounds_nav_lon/bounds_nav_lat (y, x, nvertex), zos with
 *    _FillValue 1e20 on land) gives the file's corners, its land, the
 *    cells over a box, and areas of the sphere R^2 dlon (sin lat_n -
 *    sin lat_s) within 1e-4 (the corners joined by great circles, not
 *    parallels); a file without coordinates is refused in one line naming
 *    the file, the variable and the key (grids given by their mapping
 *    alone: tests/test_ocean_grid_mapped.c). */
#include <dirent.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "tmpdir.h"
#include "core/model.h"
#include "io/ocean_fluxes.h"
#include "io/ocean_grid.h"
#include "ofx_drift.h"

#define DEG (M_PI / 180.0)
#define CLOSE(got, want, tol, ...)                       \
    do {                                                 \
        char m_[200];                                    \
        snprintf(m_, sizeof m_, __VA_ARGS__);            \
        CHECK_CLOSE(got, want, tol, 0, m_);              \
    } while (0)

static char dir[] = "/tmp/sphice-ofxc-XXXXXX";
static unsigned long long rs = 12345u;
static double rnd(void) /* splitmix64 */
{
    unsigned long long z = (rs += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) / 9007199254740992.0;
}

/* A grid built on the plane: centres, corners (anticlockwise), polygon
 * areas, lon/lat of a local map in which plane x is east (east = 0). */
enum { MAXC = 40 * 30 };
typedef struct {
    int nx, ny;
    double cx[MAXC], cy[MAXC], bx[4 * MAXC], by[4 * MAXC], lon[MAXC], lat[MAXC], blon[4 * MAXC],
        blat[4 * MAXC], area[MAXC];
    unsigned char land[MAXC];
} cgrid;

static void lonlat_of(double x, double y, double *lon, double *lat)
{
    *lon = 121.0 + x / (6371000.0 * cos(40.0 * DEG) * DEG);
    *lat = 40.0 + y / (6371000.0 * DEG);
}

static void finish(cgrid *g)
{
    for (int c = 0; c < g->nx * g->ny; c++) {
        double s = 0.0;
        for (int v = 0, u = 3; v < 4; u = v++) {
            s += g->bx[4 * c + u] * g->by[4 * c + v] - g->bx[4 * c + v] * g->by[4 * c + u];
            lonlat_of(g->bx[4 * c + v], g->by[4 * c + v], &g->blon[4 * c + v], &g->blat[4 * c + v]);
        }
        g->area[c] = 0.5 * s;
        lonlat_of(g->cx[c], g->cy[c], &g->lon[c], &g->lat[c]);
    }
}

/* nx x ny cells of side d, i axis at rot degrees from plane x (= east). */
static void rotated(cgrid *g, int nx, int ny, double d, double rot)
{
    g->nx = nx;
    g->ny = ny;
    double cr = cos(rot * DEG), sr = sin(rot * DEG);
    static const double off[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int c = j * nx + i;
            double u = (i - 0.5 * (nx - 1)) * d, v = (j - 0.5 * (ny - 1)) * d;
            g->cx[c] = u * cr - v * sr;
            g->cy[c] = u * sr + v * cr;
            for (int k = 0; k < 4; k++) {
                double uu = u + off[k][0] * d, vv = v + off[k][1] * d;
                g->bx[4 * c + k] = uu * cr - vv * sr;
                g->by[4 * c + k] = uu * sr + vv * cr;
            }
            g->land[c] = 0;
        }
    finish(g);
}

/* A polar sector: i along the radius r0 + i dr, j along the angle
 * th0 + j dth (degrees); corners at the half steps. */
static void bent(cgrid *g, int nx, int ny, double r0, double dr, double th0, double dth)
{
    g->nx = nx;
    g->ny = ny;
    static const double off[4][2] = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int c = j * nx + i;
            double r = r0 + i * dr, t = (th0 + j * dth) * DEG;
            g->cx[c] = r * cos(t);
            g->cy[c] = r * sin(t);
            for (int k = 0; k < 4; k++) {
                double rr = r + off[k][0] * dr, tt = t + off[k][1] * dth * DEG;
                g->bx[4 * c + k] = rr * cos(tt);
                g->by[4 * c + k] = rr * sin(tt);
            }
            g->land[c] = 0;
        }
    finish(g);
}

static ofx_grid as_ofx(cgrid *g, const char *corners)
{
    ofx_grid o = {.kind = OFX_GRID_CURV, .nx = g->nx, .ny = g->ny, .lon = g->lon, .lat = g->lat, .cx = g->cx,
                  .cy = g->cy, .area = g->area, .land = g->land, .projection = "+proj=test (x east)",
                  .grid_source = "test grid", .blon = g->blon, .blat = g->blat, .bx = g->bx, .by = g->by,
                  .east = NULL, .corners = corners};
    return o;
}

/* One record of variable `name` (ny * nx values) into out; 0 on success. */
static int read_record(const char *path, const char *name, size_t r, size_t ncell, double *out)
{
    int nc, v, nd, rc = -1;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR)
        return -1;
    if (nc_inq_varid(nc, name, &v) == NC_NOERR && nc_inq_varndims(nc, v, &nd) == NC_NOERR) {
        size_t st[3] = {r, 0, 0}, ct[3] = {1, 0, 0};
        int dims[3];
        nc_inq_vardimid(nc, v, dims);
        if (nd == 3) {
            nc_inq_dimlen(nc, dims[1], &ct[1]);
            nc_inq_dimlen(nc, dims[2], &ct[2]);
            rc = ct[1] * ct[2] == ncell && nc_get_vara_double(nc, v, st, ct, out) == NC_NOERR ? 0 : -1;
        } else if (nd == 2) {
            rc = nc_get_var_double(nc, v, out) == NC_NOERR ? 0 : -1;
        }
    }
    nc_close(nc);
    return rc;
}

#define NP 300
static double px[NP], py[NP], prad[NP], phi[NP], phl[NP], pw[NP], psl[NP], ptx[NP], pty[NP], psw[NP], pia[NP],
    piv[NP];
static double f1[MAXC], f2[MAXC], ang[MAXC];

static ofx_particles particles(size_t n)
{
    ofx_particles o = {.n = n, .x = px, .y = py, .radius = prad, .heat_ice = phi, .heat_lead = phl, .water = pw,
                       .salt = psl, .taux = ptx, .tauy = pty, .swbase = psw, .ice_area = pia, .ice_volume = piv};
    return o;
}

static double total(const double *a, int n)
{
    double s = 0.0;
    for (int k = 0; k < n; k++)
        s += a[k];
    return s;
}

/* sum over the water cells of field x area (x dt) */
static double integral(const char *path, const char *name, const cgrid *g, double dt)
{
    size_t n = (size_t)g->nx * g->ny;
    if (read_record(path, name, 0, n, f1))
        return NAN;
    double s = 0.0;
    for (size_t c = 0; c < n; c++)
        if (f1[c] < 1e19)
            s += f1[c] * g->area[c] * dt;
    return s;
}

/* The first np particles into one record of dt s in DIR/NAME.nc (path);
 * *lost: those the writer could not place. 1 on success. */
/* Opens DIR/NAME.nc (path) on g: ofx_open's status, *w, *err. */
static int open_on(cgrid *g, const char *name, char *path, size_t len, ofx_writer **w, sph_error *err)
{
    ofx_grid og = as_ofx(g, "test corners");
    ofx_meta m = {.title = name, .cycle_time = 0.0};
    snprintf(path, len, "%s/%s.nc", dir, name);
    *w = NULL;
    sph_error_clear(err);
    return ofx_open(w, &og, &m, path, err);
}

static int write_one(cgrid *g, const char *name, size_t np, double dt, char *path, size_t len, size_t *lost)
{
    ofx_writer *w;
    sph_error err;
    ofx_particles o = particles(np);
    int ok = open_on(g, name, path, len, &w, &err) == SPH_OK && ofx_add_particles(w, &o, &err) == SPH_OK &&
             ofx_write_record(w, 0.0, dt, &err) == SPH_OK;
    *lost = ofx_lost(w);
    if (ok)
        ok = ofx_close(w, &err) == SPH_OK;
    else
        ofx_abort(w);
    CHECK(ok, "%s: file written: %s", name, err.msg);
    return ok;
}

/* A random point inside cell c (bilinear in its corners). */
static void inside(const cgrid *g, int c, double *x, double *y)
{
    double a = rnd(), b = rnd();
    const double *X = g->bx + 4 * c, *Y = g->by + 4 * c;
    *x = (1 - a) * (1 - b) * X[0] + a * (1 - b) * X[1] + a * b * X[2] + (1 - a) * b * X[3];
    *y = (1 - a) * (1 - b) * Y[0] + a * (1 - b) * Y[1] + a * b * Y[2] + (1 - a) * b * Y[3];
}

/* Random particles in random cells (land too; footprints from a twentieth
 * of a cell to several cells, reaching beyond the grid's edge), the last
 * `off` far off the grid; writes one record and checks its integrals. */
static int conservation(cgrid *g, const char *name, double cell, int off, char *path, size_t len)
{
    for (int k = 0; k < NP; k++) {
        inside(g, (int)(rnd() * g->nx * g->ny) % (g->nx * g->ny), &px[k], &py[k]);
        if (k >= NP - off)
            px[k] += 100.0 * cell * g->nx;
        prad[k] = cell * (k % 9 == 0 ? 0.05 : 0.3 + 3.0 * rnd());
        phi[k] = -1e9 * rnd();
        phl[k] = 1e9 * (rnd() - 0.6);
        pw[k] = 1e5 * (rnd() - 0.5);
        psl[k] = 1e3 * (rnd() - 0.5);
        ptx[k] = 1e7 * (rnd() - 0.5);
        pty[k] = 1e7 * (rnd() - 0.5);
        psw[k] = 1e8 * rnd();
        pia[k] = 1e6 * rnd();
        piv[k] = 0.7 * pia[k] * rnd();
    }
    const double dt = 1800.0;
    size_t lost = 0;
    if (!write_one(g, name, NP, dt, path, len, &lost))
        return -1;
    CHECK(lost == (size_t)off, "%s: the %d particles off the grid are counted, not placed (%zu)", name, off, lost);
    int n1 = NP - off;
    const double tol = 1e-10;
    CLOSE(integral(path, "hfds", g, dt), total(phi, n1) + total(phl, n1), tol, "%s: hfds conserves", name);
    CLOSE(integral(path, "hfsithermds", g, dt), total(phi, n1), tol, "%s: hfsithermds conserves", name);
    CLOSE(integral(path, "siflfwbot", g, dt), total(pw, n1), tol, "%s: fresh water conserves", name);
    CLOSE(integral(path, "siflsaltbot", g, dt), total(psl, n1), tol, "%s: salt conserves", name);
    CLOSE(integral(path, "siflswdbot", g, dt), total(psw, n1), tol, "%s: shortwave conserves", name);
    CLOSE(integral(path, "siconc", g, 1.0), total(pia, n1), tol, "%s: ice area conserves", name);
    CLOSE(integral(path, "sivol", g, 1.0), total(piv, n1), tol, "%s: ice volume conserves", name);
    /* the stress: the file's i/j components turned back by its angle (east = plane x here) */
    size_t n = (size_t)g->nx * g->ny;
    double sx = 0.0, sy = 0.0, bx = 0.0, by = 0.0;
    int rd = read_record(path, "tauuo", 0, n, f1) || read_record(path, "tauvo", 0, n, f2) ||
             read_record(path, "angle", 0, n, ang);
    int land_fill = 1;
    for (size_t c = 0; !rd && c < n; c++) {
        if (g->land[c]) {
            land_fill &= f1[c] > 1e19 && f2[c] > 1e19;
            continue;
        }
        sx += (f1[c] * cos(ang[c]) - f2[c] * sin(ang[c])) * g->area[c] * dt;
        sy += (f1[c] * sin(ang[c]) + f2[c] * cos(ang[c])) * g->area[c] * dt;
    }
    CHECK(!rd && land_fill, "%s: stress read, land cells are fill", name);
    CLOSE(sx, total(ptx, n1), tol, "%s: stress x conserves (turned back from i/j)", name);
    CLOSE(sy, total(pty, n1), tol, "%s: stress y conserves (turned back from i/j)", name);
    rd = read_record(path, "sistrxubot", 0, n, f2);
    for (size_t c = 0; !rd && c < n; c++) {
        read_record(path, "tauuo", 0, n, f1);
        break;
    }
    int opposite = !rd;
    for (size_t c = 0; !rd && c < n; c++)
        opposite &= g->land[c] || f2[c] == -f1[c];
    CHECK(opposite, "%s: sistrxubot = -tauuo", name);
    bx = integral(path, "hfds", g, dt);
    by = total(phi, n1) + total(phl, n1);
    printf("  %s: hfds %.17g J vs particles %.17g J; stress x %.17g vs %.17g N s\n", name, bx, by, sx,
           total(ptx, n1));
    return 0;
}

/* The file's angle against 30 degrees (polar: each centre's polar angle,
 * the bent grid's radial i axis); the worst difference, HUGE_VAL unread. */
static double angle_worst(const char *path, const cgrid *g, int polar)
{
    size_t n = (size_t)g->nx * g->ny;
    if (read_record(path, "angle", 0, n, ang))
        return HUGE_VAL;
    double worst = 0.0;
    for (size_t c = 0; c < n; c++)
        worst = fmax(worst, fabs(ang[c] - (polar ? atan2(g->cy[c], g->cx[c]) : 30.0 * DEG)));
    return worst;
}

/* conservation() and the file's angle: 30 degrees, or (polar) each
 * centre's polar angle, within 1e-12. 0 when the file was written. */
static int grid_case(cgrid *g, const char *name, double cell, int off, int polar, char *path, size_t len)
{
    if (conservation(g, name, cell, off, path, len))
        return -1;
    double worst = angle_worst(path, g, polar);
    CHECK(worst <= 1e-12, "%s: angle = %s in every cell (worst %.3g rad)", name,
          polar ? "the polar angle of the centre" : "30 degrees", worst);
    return 0;
}

static void rotated_grid(void)
{
    static cgrid g;
    const double d = 2000.0;
    rotated(&g, 30, 20, d, 30.0);
    for (int c = 0; c < g.nx * g.ny; c++) /* a land block in one corner and a strip */
        g.land[c] = (c % g.nx >= 27 && c / g.nx >= 17) || (c % g.nx == 10 && c / g.nx < 8);
    char path[1024];
    if (grid_case(&g, "rotated", d, 12, 0, path, sizeof path))
        return;
    size_t n = (size_t)g.nx * g.ny;
    int ok;

    /* a uniform eastward stress: tau_i = |tau| cos 30, tau_j = -|tau| sin 30 per cell */
    for (int k = 0; k < NP; k++) {
        ptx[k] = 2.5e6 * (0.5 + rnd()); /* N s, eastward */
        pty[k] = 0.0;
        pw[k] = ptx[k]; /* the same amount as a scalar: its gridded value is the cell's magnitude */
        inside(&g, (int)(rnd() * g.nx * g.ny) % (g.nx * g.ny), &px[k], &py[k]);
        prad[k] = d * (0.3 + 2.0 * rnd());
    }
    size_t lost = 0;
    ok = write_one(&g, "east", NP, 600.0, path, sizeof path, &lost);
    static double mag[MAXC];
    ok = ok && !read_record(path, "tauuo", 0, n, f1) && !read_record(path, "tauvo", 0, n, f2) &&
         !read_record(path, "siflfwbot", 0, n, mag);
    double e1 = 0.0, e2 = 0.0;
    size_t cells = 0;
    for (size_t c = 0; ok && c < n; c++) {
        if (g.land[c] || mag[c] == 0.0)
            continue;
        cells++;
        e1 = fmax(e1, fabs(f1[c] - mag[c] * cos(30.0 * DEG)) / mag[c]);
        e2 = fmax(e2, fabs(f2[c] + mag[c] * sin(30.0 * DEG)) / mag[c]);
    }
    printf("  eastward stress on a 30-degree grid: %zu cells, worst |tau_i/|tau| - cos 30| %.3g, "
           "|tau_j/|tau| + sin 30| %.3g\n", cells, e1, e2);
    CHECK(ok && cells > 100 && e1 <= 1e-12 && e2 <= 1e-12,
          "eastward stress: grid components (cos 30, -sin 30) of its magnitude within 1e-12 (%.3g, %.3g)", e1, e2);
}

static void bent_grid(void)
{
    static cgrid g;
    const double r0 = 20000.0, dr = 1500.0;
    bent(&g, 24, 30, r0, dr, 10.0, 2.5);
    for (int c = 0; c < g.nx * g.ny; c++) /* the coast: the outer radii of the first rows */
        g.land[c] = c % g.nx >= 23 && c / g.nx < 12;
    char path[1024];
    if (grid_case(&g, "bent", dr, 7, 1, path, sizeof path))
        return;
    size_t n = (size_t)g.nx * g.ny;
    int ok;

    /* one particle wholly inside a land cell next to the water: the
     * nearest water cell takes all */
    size_t land_cell = 5 * g.nx + 23;
    px[0] = g.cx[land_cell];
    py[0] = g.cy[land_cell];
    prad[0] = 0.2 * dr;
    pw[0] = 1234.5;
    phi[0] = phl[0] = psl[0] = ptx[0] = pty[0] = psw[0] = pia[0] = piv[0] = 0.0;
    size_t lost = 1;
    ok = write_one(&g, "land", 1, 100.0, path, sizeof path, &lost) && lost == 0;
    CHECK(ok, "a particle on land: placed (lost %zu)", lost);
    ok = ok && !read_record(path, "siflfwbot", 0, n, f1);
    size_t got = (size_t)-1, nz = 0;
    double best = HUGE_VAL;
    size_t nearest = 0;
    for (size_t c = 0; ok && c < n; c++) {
        if (!g.land[c] && f1[c] != 0.0) {
            got = c;
            nz++;
        }
        double dd = hypot(g.cx[c] - px[0], g.cy[c] - py[0]);
        if (!g.land[c] && dd < best) {
            best = dd;
            nearest = c;
        }
    }
    CHECK(ok && nz == 1 && got == nearest, "a particle on land goes whole to the nearest water cell (%zu, want %zu)",
          got, nearest);
    CHECK(ok && got < n && fabs(f1[got] * g.area[got] * 100.0 - 1234.5) <= 1e-10 * 1234.5,
          "and it conserves: %.17g kg", ok && got < n ? f1[got] * g.area[got] * 100.0 : NAN);
}

/* Steady free drift, then the particle's stress on a rotated grid around it. */
static void drag(void)
{
    ofx_drift dr;
    int ok = ofx_drift_run(&dr, 4.0, 9.0, -0.08, 0.12, 40) == 0;
    CHECK(ok, "free drift");
    sph_model *m = dr.m;
    sph_particles *P = dr.P;
    double fp = dr.fp, T = dr.T, dx_ = dr.drag[0], dy_ = dr.drag[1];
    static cgrid g;
    rotated(&g, 9, 9, 1000.0, -20.0);
    for (int c = 0; c < g.nx * g.ny; c++) { /* centred on the particle */
        g.cx[c] += P->x[0];
        g.cy[c] += P->y[0];
        for (int v = 0; v < 4; v++) {
            g.bx[4 * c + v] += P->x[0];
            g.by[4 * c + v] += P->y[0];
        }
    }
    char path[1024];
    px[0] = P->x[0];
    py[0] = P->y[0];
    prad[0] = 2500.0;
    ptx[0] = P->ofx_taux[0];
    pty[0] = P->ofx_tauy[0];
    phi[0] = phl[0] = pw[0] = psl[0] = psw[0] = 0.0;
    pia[0] = piv[0] = fp;
    size_t lost = 1;
    ok = write_one(&g, "drag", 1, T, path, sizeof path, &lost) && lost == 0;
    size_t n = (size_t)g.nx * g.ny;
    ok = ok && !read_record(path, "tauuo", 0, n, f1) && !read_record(path, "tauvo", 0, n, f2) &&
         !read_record(path, "angle", 0, n, ang);
    double sx = 0.0, sy = 0.0;
    for (size_t c = 0; ok && c < n; c++) {
        sx += (f1[c] * cos(ang[c]) - f2[c] * sin(ang[c])) * g.area[c];
        sy += (f1[c] * sin(ang[c]) + f2[c] * cos(ang[c])) * g.area[c];
    }
    CHECK(ok, "drag file read");
    CHECK_CLOSE(sx / fp, -dx_, 1e-10, 0, "file on a rotated grid: stress on the ocean x = minus the water drag");
    CHECK_CLOSE(sy / fp, -dy_, 1e-10, 0, "file on a rotated grid: stress on the ocean y = minus the water drag");
    printf("  stress on the ocean (%.12g, %.12g) N/m2, minus the drag (%.12g, %.12g)\n", sx / fp, sy / fp, -dx_,
           -dy_);
    sph_model_free(m);
}

/* Grids the writer cannot orient: one line, nothing written. */
static void refused(void)
{
    static cgrid g;
    rotated(&g, 6, 5, 1000.0, 0.0);
    for (int c = 0; c < g.nx * g.ny; c++) { /* corners clockwise: a left-handed grid */
        double t = g.bx[4 * c + 1];
        g.bx[4 * c + 1] = g.bx[4 * c + 3];
        g.bx[4 * c + 3] = t;
        t = g.by[4 * c + 1];
        g.by[4 * c + 1] = g.by[4 * c + 3];
        g.by[4 * c + 3] = t;
    }
    char path[1024];
    ofx_writer *w;
    sph_error err;
    int rc = open_on(&g, "bad", path, sizeof path, &w, &err);
    CHECK(rc != SPH_OK && strstr(err.msg, "anticlockwise") && strstr(err.msg, "output.ocean_fluxes_grid") &&
              !strchr(err.msg, '\n') && access(path, F_OK) != 0,
          "clockwise corners refused in one line: %s", err.msg);
    /* a skewed grid: j at 45 degrees from i */
    rotated(&g, 6, 5, 1000.0, 0.0);
    for (int c = 0; c < g.nx * g.ny; c++) {
        double sh = 1.0; /* x += y: the j axis at 45 degrees */
        g.cx[c] += sh * g.cy[c];
        for (int v = 0; v < 4; v++)
            g.bx[4 * c + v] += sh * g.by[4 * c + v];
    }
    rc = open_on(&g, "bad", path, sizeof path, &w, &err);
    CHECK(rc != SPH_OK && strstr(err.msg, "45.0 degrees") && !strchr(err.msg, '\n') && access(path, F_OK) != 0,
          "a skewed grid refused in one line: %s", err.msg);
}


/* NEMO output as XIOS writes it: 8 x 6 cells of 0.1 degree from
 * (121.0 E, 40.0 N), land from x = 6 east. */
static void nemo_file(const char *path)
{
    enum { NX = 8, NY = 6 };
    int nc, dx, dy, dv, dt, vlon, vlat, vbl, vbb, vt, vz;
    nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc);
    nc_def_dim(nc, "x", NX, &dx);
    nc_def_dim(nc, "y", NY, &dy);
    nc_def_dim(nc, "nvertex", 4, &dv);
    nc_def_dim(nc, "time_counter", NC_UNLIMITED, &dt);
    int d2[2] = {dy, dx}, d3[3] = {dy, dx, dv}, dz[3] = {dt, dy, dx};
    /* name, standard_name, units, bounds */
    static const char *const co[2][4] = {{"nav_lat", "latitude", "degrees_north", "bounds_nav_lat"},
                                         {"nav_lon", "longitude", "degrees_east", "bounds_nav_lon"}};
    for (int k = 0; k < 2; k++) {
        int *v = k ? &vlon : &vlat;
        nc_def_var(nc, co[k][0], NC_DOUBLE, 2, d2, v);
        for (int a = 1; a < 4; a++)
            nc_put_att_text(nc, *v, a == 1 ? "standard_name" : a == 2 ? "units" : "bounds", strlen(co[k][a]),
                            co[k][a]);
    }
    nc_def_var(nc, "bounds_nav_lat", NC_DOUBLE, 3, d3, &vbb);
    nc_def_var(nc, "bounds_nav_lon", NC_DOUBLE, 3, d3, &vbl);
    nc_def_var(nc, "time_counter", NC_DOUBLE, 1, &dt, &vt);
    nc_def_var(nc, "zos", NC_FLOAT, 3, dz, &vz);
    static const char *const at[5][2] = {{"standard_name", "time"},
                                         {"units", "seconds since 1900-01-01 00:00:00"},
                                         {"standard_name", "sea_surface_height_above_geoid"},
                                         {"units", "m"},
                                         {"coordinates", "time_centered nav_lat nav_lon"}};
    for (int a = 0; a < 5; a++)
        nc_put_att_text(nc, a < 2 ? vt : vz, at[a][0], strlen(at[a][1]), at[a][1]);
    float fv = 1e20f;
    nc_put_att_float(nc, vz, "_FillValue", NC_FLOAT, 1, &fv);
    nc_put_att_float(nc, vz, "missing_value", NC_FLOAT, 1, &fv);
    nc_enddef(nc);
    double lon[NY * NX], lat[NY * NX], bl[NY * NX * 4], bb[NY * NX * 4], t = 3.1e9;
    float z[NY * NX];
    static const double off[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int c = 0; c < NX * NY; c++) {
        lon[c] = 121.05 + 0.1 * (c % NX);
        lat[c] = 40.05 + 0.1 * (c / NX);
        for (int v = 0; v < 4; v++) {
            bl[4 * c + v] = lon[c] + 0.05 * off[v][0];
            bb[4 * c + v] = lat[c] + 0.05 * off[v][1];
        }
        z[c] = c % NX >= 6 ? 1e20f : 0.1f;
    }
    size_t st[3] = {0, 0, 0}, ct[3] = {1, NY, NX}, t0 = 0;
    nc_put_var_double(nc, vlat, lat);
    nc_put_var_double(nc, vlon, lon);
    nc_put_var_double(nc, vbb, bb);
    nc_put_var_double(nc, vbl, bl);
    nc_put_var1_double(nc, vt, &t0, &t);
    nc_put_vara_float(nc, vz, st, ct, z);
    nc_close(nc);
}

/* A 2-D field without coordinates. */
static void bad_file(const char *path)
{
    int nc, dx, dy, vu;
    nc_create(path, NC_NETCDF4 | NC_CLOBBER, &nc);
    nc_def_dim(nc, "x", 6, &dx);
    nc_def_dim(nc, "y", 5, &dy);
    int d2[2] = {dy, dx};
    nc_def_var(nc, "uo", NC_FLOAT, 2, d2, &vu);
    nc_put_att_text(nc, vu, "standard_name", 27, "eastward_sea_water_velocity");
    nc_put_att_text(nc, vu, "units", 5, "m s-1");
    nc_enddef(nc);
    float u[30];
    for (int k = 0; k < 30; k++)
        u[k] = 0.1f;
    nc_put_var_float(nc, vu, u);
    nc_close(nc);
}

static void reader(void)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nemo_T.nc", dir);
    nemo_file(path);
    const double all[4] = {120.0, 123.0, 39.0, 41.5};
    ocean_grid *g = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ocean_grid_read(path, all, "output.ocean_fluxes_grid", &g, &err);
    CHECK(rc == SPH_OK && g && g->nx == 8 && g->ny == 6, "NEMO file read: %s", err.msg);
    if (rc == SPH_OK && g) {
        CHECK(strstr(g->corners, "bounds_nav_lon") != NULL, "corners from the CF bounds: %s", g->corners);
        int corners = 1, land = 1;
        double worst = 0.0;
        static const double off[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int c = 0; c < 48; c++) {
            double lo = 121.05 + 0.1 * (c % 8), la = 40.05 + 0.1 * (c / 8);
            for (int v = 0; v < 4; v++)
                corners &= fabs(g->blon[4 * c + v] - (lo + 0.05 * off[v][0])) < 1e-12 &&
                           fabs(g->blat[4 * c + v] - (la + 0.05 * off[v][1])) < 1e-12;
            land &= g->land[c] == (c % 8 >= 6);
            double want = 6371000.0 * 6371000.0 * 0.1 * DEG * (sin((la + 0.05) * DEG) - sin((la - 0.05) * DEG));
            worst = fmax(worst, fabs(g->area[c] - want) / want);
        }
        CHECK(corners, "the cells' corners are the file's bounds");
        CHECK(land, "land where zos is fill");
        printf("  NEMO file: areas against R^2 dlon (sin lat_n - sin lat_s): worst %.3g relative (%s)\n", worst,
               g->area_from);
        CHECK(worst <= 1e-4, "areas of the sphere within 1e-4 (%.3g)", worst);
    }
    ocean_grid_free(g);
    /* the cells whose centres lie within the box widened by 0.1 degree
     * (the neighbours' spacing): box 121.26..121.34 E, 40.16..40.24 N
     * widened to 121.16..121.44, 40.06..40.34: centres 121.25, 121.35 (i 2,
     * 3) and 40.15, 40.25 (j 1, 2); box 121.21..121.24 E: 121.11..121.34, i 1, 2 */
    const double box[4] = {121.26, 121.34, 40.16, 40.24}, box2[4] = {121.21, 121.24, 40.16, 40.24};
    g = NULL;
    rc = ocean_grid_read(path, box, "output.ocean_fluxes_grid", &g, &err);
    CHECK(rc == SPH_OK && g && g->i0 == 2 && g->j0 == 1 && g->nx == 2 && g->ny == 2,
          "the cells over a box: i %d +%d, j %d +%d", g ? g->i0 : -1, g ? g->nx : -1, g ? g->j0 : -1, g ? g->ny : -1);
    ocean_grid_free(g);
    g = NULL;
    rc = ocean_grid_read(path, box2, "output.ocean_fluxes_grid", &g, &err);
    CHECK(rc == SPH_OK && g && g->i0 == 1 && g->j0 == 1 && g->nx == 2 && g->ny == 2,
          "the cells over a box: i %d +%d, j %d +%d", g ? g->i0 : -1, g ? g->nx : -1, g ? g->j0 : -1, g ? g->ny : -1);
    ocean_grid_free(g);

    snprintf(path, sizeof path, "%s/nocoords.nc", dir); /* a rotated pole is read: test_ocean_grid_mapped */
    bad_file(path);
    g = NULL;
    sph_error_clear(&err);
    rc = ocean_grid_read(path, all, "output.ocean_fluxes_grid", &g, &err);
    CHECK(rc != SPH_OK && !g && strstr(err.msg, path) && strstr(err.msg, "variable uo") &&
              strstr(err.msg, "output.ocean_fluxes_grid") && !strchr(err.msg, '\n'),
          "a file without coordinates refused in one line naming the file, the variable and the key: %s", err.msg);
    printf("  nocoords.nc: %s\n", err.msg);
}

/* The mixed layer's cells on a curvilinear grid: ofx_locate gives the cell
 * whose polygon holds a point (a land cell's point: the nearest water
 * centre), and a cell's plane stress goes to the target cell's i/j. */
static void cells(void)
{
    static cgrid g;
    rotated(&g, 8, 6, 1000.0, 30.0);
    for (int c = 0; c < 48; c++)
        g.land[c] = c == 13;
    char path[1024];
    ofx_writer *w;
    sph_error err;
    CHECK(open_on(&g, "cells", path, sizeof path, &w, &err) == SPH_OK, "open: %s", err.msg);
    if (!w)
        return;
    int found = 1;
    for (int c = 0; c < 48; c++) {
        double x, y;
        inside(&g, c, &x, &y);
        long to = ofx_locate(w, NAN, NAN, x, y, 1500.0);
        if (c == 13) { /* land: the nearest water centre */
            double best = HUGE_VAL;
            long want = -1;
            for (int q = 0; q < 48; q++)
                if (q != 13 && hypot(g.cx[q] - x, g.cy[q] - y) < best) {
                    best = hypot(g.cx[q] - x, g.cy[q] - y);
                    want = q;
                }
            found &= to == want;
        } else {
            found &= to == c;
        }
    }
    CHECK(found, "ofx_locate: the cell holding the point, the nearest water for land");
    CHECK(ofx_locate(w, NAN, NAN, 1e6, 1e6, 1500.0) == -1, "a point far off the grid: none");
    /* one source cell with 2 N s eastward (plane x) and 7 J into cell 20 */
    long to = 20;
    double heat = 7.0, zero = 0.0, tx = 2.0, dt = 10.0;
    CHECK(ofx_add_ocean_cells(w, 1, &to, NULL, &heat, &zero, &zero, &zero, &tx, &zero, &zero, dt, NULL, &err) ==
              SPH_OK && ofx_write_record(w, 0.0, dt, &err) == SPH_OK && ofx_close(w, &err) == SPH_OK,
          "cells added: %s", err.msg);
    int ok = !read_record(path, "tauuo", 0, 48, f1) && !read_record(path, "tauvo", 0, 48, f2) &&
             !read_record(path, "hfds", 0, 48, ang);
    double a = g.area[20] * dt;
    CHECK(ok && fabs(f1[20] * a - 2.0 * cos(30.0 * DEG)) <= 1e-12 && fabs(f2[20] * a + 2.0 * sin(30.0 * DEG)) <= 1e-12 &&
              fabs(ang[20] * a - 7.0) <= 1e-12,
          "a cell's stress along the target's i/j: (%.15g, %.15g) = 2 (cos 30, -sin 30); heat %.15g J", f1[20] * a,
          f2[20] * a, ang[20] * a);
}

int main(void)
{
    int made = mkdtemp(dir) != NULL;
    CHECK(made, "a temporary directory");
    void (*const parts[])(void) = {rotated_grid, bent_grid, drag, refused, reader, cells};
    for (size_t k = 0; made && k < sizeof parts / sizeof parts[0]; k++)
        parts[k]();
    /* the files are all directly in dir */
    if (made)
        tmpdir_remove(dir);
    return check_summary("test_ocean_fluxes_curv");
}
