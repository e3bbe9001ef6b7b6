/* Coasts: land mask queries, mirror ghosts and their velocity and stress,
 * moves blocked by land, and outflow at open boundaries. */
#include "model_impl.h"

#include <math.h>

#include "core/model.h"

/* ------------------------------------------------------------------ */
/* land mask                                                           */

static int mask_cell(const sph_model *m, double x, double y, int *ci, int *cj)
{
    const sph_landmask *k = &m->mask;
    double fi = floor((x - k->x0) / k->dx), fj = floor((y - k->y0) / k->dy);
    /* written so that a NaN position is outside (no out-of-range index) */
    if (!(fi >= 0 && fj >= 0 && fi < k->nx && fj < k->ny))
        return 0;
    *ci = (int)fi;
    *cj = (int)fj;
    return 1;
}

/* 1 if the point is land (or outside a closed domain). */
int sph_is_land(const sph_model *m, double x, double y)
{
    if (!m->has_mask)
        return 0;
    int i, j;
    if (!mask_cell(m, x, y, &i, &j))
        return m->mask.closed_outside;
    return m->land[(size_t)j * m->mask.nx + i] != 0;
}

/* 1 if the point is sea inside the domain: not land and, with an open
 * mask, not beyond its grid (where particles leave as outflow). */
int sph_is_domain_sea(const sph_model *m, double x, double y)
{
    if (!m->has_mask)
        return 1;
    int i, j;
    if (!mask_cell(m, x, y, &i, &j))
        return 0;
    return m->land[(size_t)j * m->mask.nx + i] == 0;
}

/* A move from (x0, y0) whose target (*x1, *y1) is land: slide along the
 * coast (keep the sea-side component, zero the other velocity component)
 * or stop. */
static inline void blocked_move(const sph_model *m, sph_particles *P, size_t k, double x0, double y0,
                                double *x1, double *y1)
{
    if (!sph_is_land(m, *x1, y0)) {
        *y1 = y0;
        P->v[k] = 0.0;
    } else if (!sph_is_land(m, x0, *y1)) {
        *x1 = x0;
        P->u[k] = 0.0;
    } else {
        *x1 = x0;
        *y1 = y0;
        P->u[k] = P->v[k] = 0.0;
    }
}

static int outside_open(const sph_model *m, double x, double y)
{
    /* a non-finite position is a blow-up for check_health to report, not outflow */
    if (!m->has_mask || m->mask.closed_outside || !isfinite(x) || !isfinite(y))
        return 0;
    int i, j;
    return !mask_cell(m, x, y, &i, &j);
}

static int land_at(const sph_model *m, int i, int j)
{
    const sph_landmask *k = &m->mask;
    if (i < 0 || j < 0 || i >= k->nx || j >= k->ny)
        return k->closed_outside;
    return k->land[(size_t)j * k->nx + i] != 0;
}

/* near_land[c] = 1 where a land cell (land_at: outside the mask counts as
 * land in a closed domain) lies within ri columns and rj rows of c. The
 * window is a rectangle, so the test separates: along each row a sliding
 * count of land over [i - ri, i + ri], kept in bit 1 of near_land; down
 * each column a sliding count of those rows over [j - rj, j + rj] into bit
 * 0. O(nx ny) whatever the radius (the direct scan of every window cost
 * (2 ri + 1) (2 rj + 1) per cell: 0.4 s for the mask of a run of 1e5
 * particles), the same cells (tests/test_near_land.c). */
void sph_mark_near_land(sph_model *m, double radius)
{
    m->near_radius = radius;
    sph_mark_land_within(m, radius, m->near_land);
}

void sph_mark_land_within(const sph_model *m, double radius, unsigned char *nl)
{
    const sph_landmask *k = &m->mask;
    const long nx = k->nx, ny = k->ny;
    const long ri = (long)ceil(radius / k->dx) + 1, rj = (long)ceil(radius / k->dy) + 1;
    const int out = k->closed_outside != 0;
    for (long j = 0; j < ny; j++) {
        const unsigned char *row = k->land + (size_t)j * (size_t)nx;
        unsigned char *dst = nl + (size_t)j * (size_t)nx;
        long cnt = 0;
        for (long c = -ri; c <= ri; c++)
            cnt += c < 0 || c >= nx ? out : row[c] != 0;
        for (long i = 0; i < nx; i++) {
            dst[i] = cnt > 0 ? 2 : 0;
            long in = i + 1 + ri, gone = i - ri;
            cnt += (in >= nx ? out : row[in] != 0) - (gone < 0 ? out : row[gone] != 0);
        }
    }
    for (long i = 0; i < nx; i++) {
        long cnt = 0;
        for (long b = -rj; b <= rj; b++)
            cnt += b < 0 || b >= ny ? out : (nl[(size_t)b * (size_t)nx + (size_t)i] & 2) != 0;
        for (long j = 0; j < ny; j++) {
            unsigned char *c = nl + (size_t)j * (size_t)nx + (size_t)i;
            *c = (unsigned char)(*c | (cnt > 0));
            long in = j + 1 + rj, gone = j - rj;
            cnt += (in >= ny ? out : (nl[(size_t)in * (size_t)nx + (size_t)i] & 2) != 0) -
                   (gone < 0 ? out : (nl[(size_t)gone * (size_t)nx + (size_t)i] & 2) != 0);
        }
    }
    for (size_t c = 0; c < (size_t)nx * (size_t)ny; c++)
        nl[c] &= 1;
}

/* Nearest land cell (as a rectangle) within radius: distance and the unit
 * normal pointing from the coast into the sea. Returns 0 if none. */
/* With (exnx, exny) non-zero, only land in front of the first wall's
 * tangent line through (exx, exy) counts: a second, different wall. */
static int nearest_coast(const sph_model *m, double x, double y, double radius, double *dist,
                         double *nx, double *ny, double exx, double exy, double exnx, double exny)
{
    const sph_landmask *k = &m->mask;
    int ci, cj;
    if (!mask_cell(m, x, y, &ci, &cj))
        return 0;
    if (!m->near_land[(size_t)cj * k->nx + ci])
        return 0;
    int ri = (int)ceil(radius / k->dx) + 1, rj = (int)ceil(radius / k->dy) + 1;
    double best = radius, bx = 0, by = 0;
    int found = 0;
    for (int j = cj - rj; j <= cj + rj; j++)
        for (int i = ci - ri; i <= ci + ri; i++) {
            if (!land_at(m, i, j))
                continue;
            double xl = k->x0 + i * k->dx, yl = k->y0 + j * k->dy;
            double px = fmin(fmax(x, xl), xl + k->dx), py = fmin(fmax(y, yl), yl + k->dy);
            double d = hypot(x - px, y - py);
            /* a second wall: its nearest point lies in front of the first
             * wall (not another point of the same coast) */
            if ((exnx != 0.0 || exny != 0.0) &&
                (px - exx) * exnx + (py - exy) * exny <= 1e-6 * k->dx)
                continue;
            if (d < best && d > 0.0) {
                best = d;
                bx = px;
                by = py;
                found = 1;
            }
        }
    if (!found)
        return 0;
    *dist = best;
    *nx = (x - bx) / best;
    *ny = (y - by) / best;
    return 1;
}

/* Mirror ghosts: each live particle within the kernel support of a coast
 * is reflected across the local coast line (the tangent at the nearest
 * land point); near a second wall facing another way (a corner) it is
 * also reflected across that one, and across both. Ghosts carry the
 * source's mass, density, thickness and strength, mirrored velocity (free
 * slip: normal component reversed; no slip: whole velocity reversed) and
 * mirrored stress R S R, R = I - 2 n n^T (applied per wall).
 *
 * A reflection across a straight coast keeps distances: the ghosts are as
 * dense as their sources. Across a coast curved tighter than the kernel
 * support (an island or headland a few smoothing lengths across, a
 * stair-step corner) the reflections of sources around it converge: their
 * ghosts pile up inside it, several times denser than the ice, and a
 * particle next to it gets more neighbours than max_neighbours (a 7 km
 * island with 10 km of support: 19 real neighbours and 84 ghosts). So a
 * ghost is left out when an earlier ghost lies within GHOST_MIN_SEP of its
 * source's smoothing length while their sources lie more than
 * GHOST_CONTRACTION times as far apart: the mirror has contracted them, and
 * the earlier ghost takes its volume (mass / density), so that the land's
 * share of every kernel sum stays what the reflections give, on fewer
 * particles; the summation density sums their mass (ghost_mass), not
 * that volume at the earlier ghost's density. Ghosts of a straight or gently
 * curved coast (contraction below the factor) are all kept. Merging starts
 * only when a neighbour list first overflows max_neighbours (model.c,
 * prepare_lists) and stays on for the model's life: below that the
 * reflections are kept one for one (a stair-step coast at the grid scale
 * has such pairs everywhere, harmless while the lists hold them). */
#define GHOST_MIN_SEP 0.5
#define GHOST_CONTRACTION 2.0

static size_t gh_bucket(const sph_model *m, double x, double y, long *ix, long *iy)
{
    *ix = (long)floor(x / m->gh_cell);
    *iy = (long)floor(y / m->gh_cell);
    unsigned long long h = (unsigned long long)*ix * 0x9E3779B97F4A7C15ull ^
                           (unsigned long long)*iy * 0xC2B2AE3D27D4EB4Full;
    return (size_t)(h >> 20) & (m->gh_size - 1);
}

/* An earlier ghost within GHOST_MIN_SEP * sml of (gx, gy) whose source
 * lies more than GHOST_CONTRACTION times as far from k as the ghosts are
 * from each other (its index after the live particles), or -1. */
static long ghost_crowded(const sph_model *m, size_t k, double gx, double gy)
{
    const sph_particles *P = m->P;
    double r = GHOST_MIN_SEP * P->sml[k];
    if (!(r > 0.0) || !(m->gh_cell > 0.0) || !isfinite(gx) || !isfinite(gy))
        return -1;
    long cx, cy;
    gh_bucket(m, gx, gy, &cx, &cy);
    for (long by = cy - 1; by <= cy + 1; by++)
        for (long bx = cx - 1; bx <= cx + 1; bx++) {
            long ix, iy;
            size_t b = gh_bucket(m, (bx + 0.5) * m->gh_cell, (by + 0.5) * m->gh_cell, &ix, &iy);
            for (int g = m->gh_head[b]; g >= 0; g = m->gh_next[g]) {
                size_t q = P->n + (size_t)g, s = (size_t)m->ghost_src[g];
                double d = hypot(P->x[q] - gx, P->y[q] - gy);
                if (d < r && hypot(P->x[s] - P->x[k], P->y[s] - P->y[k]) > GHOST_CONTRACTION * d)
                    return (long)q;
            }
        }
    return -1;
}

static int add_ghost(sph_model *m, size_t k, double gx, double gy, double n1x, double n1y,
                     double n2x, double n2y)
{
    sph_particles *P = m->P;
    size_t q = P->n + m->ng;
    if (q >= P->cap)
        return 0;
    long c = m->ghost_merge ? ghost_crowded(m, k, gx, gy) : -1;
    if (c >= 0) {
        /* the ghost there takes this one's volume (mass / density): the
         * land's share of the kernel sums is kept, on one particle */
        size_t g = (size_t)c;
        if (P->dens[k] > 0.0 && P->dens[g] > 0.0)
            P->mass[g] += P->mass[k] * P->dens[g] / P->dens[k];
        else
            P->mass[g] += P->mass[k];
        /* the mass sums (the summation density) take the reflection's mass:
         * the volume above at g's density is dens[g] / dens[k] times it, and
         * dens[g] is its source's summation density, which sums this ghost:
         * a dense particle's own merged ghost made it denser step after
         * step (the freeze-up scene's pile-up, docs/ocean.md) */
        m->ghost_mass[g - P->n] += P->mass[k];
        m->ghosts_thinned++;
        return 0;
    }
    sph_particles_copy_one(P, q, P, k);
    m->ghost_mass[m->ng] = P->mass[k];
    P->x[q] = gx;
    P->y[q] = gy;
    m->ghost_src[m->ng] = (int)k;
    m->ghost_nx[m->ng] = n1x;
    m->ghost_ny[m->ng] = n1y;
    m->ghost_n2x[m->ng] = n2x;
    m->ghost_n2y[m->ng] = n2y;
    if (m->ghost_merge && m->gh_cell > 0.0 && isfinite(gx) && isfinite(gy)) {
        long ix, iy;
        size_t b = gh_bucket(m, gx, gy, &ix, &iy);
        m->gh_next[m->ng] = m->gh_head[b];
        m->gh_head[b] = (int)m->ng;
    }
    m->ng++;
    return 1;
}

void sph_build_ghosts(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    m->ng = 0;
    m->ghosts_thinned = 0;
    if (!m->has_mask)
        return;
    /* the hash's cells cover the largest thinning radius */
    m->gh_cell = GHOST_MIN_SEP * sph_max_sml(P, n);
    /* the hash is read only while merging (ghost_crowded): without it its
     * heads (4 bytes per slot of the 4 x capacity) are never touched */
    if (m->ghost_merge)
        for (size_t b = 0; b < m->gh_size; b++)
            m->gh_head[b] = -1;
    for (size_t k = 0; k < n; k++) {
        double radius = m->kern.radius * P->sml[k];
        double d1, n1x, n1y, d2, n2x, n2y;
        double x = P->x[k], y = P->y[k];
        P->regime[k] &= (unsigned char)~SPH_REGIME_NEAR_COAST;
        if (!nearest_coast(m, x, y, radius, &d1, &n1x, &n1y, 0.0, 0.0, 0.0, 0.0))
            continue;
        P->regime[k] |= SPH_REGIME_NEAR_COAST;
        double g1x = x - 2.0 * d1 * n1x, g1y = y - 2.0 * d1 * n1y;
        add_ghost(m, k, g1x, g1y, n1x, n1y, 0.0, 0.0);
        if (nearest_coast(m, x, y, radius, &d2, &n2x, &n2y, x - d1 * n1x, y - d1 * n1y, n1x,
                          n1y)) {
            add_ghost(m, k, x - 2.0 * d2 * n2x, y - 2.0 * d2 * n2y, n2x, n2y, 0.0, 0.0);
            /* a corner (walls at an angle) also needs the doubly mirrored ghost;
             * facing walls (a channel) do not */
            if (fabs(n1x * n2x + n1y * n2y) < 0.5)
                add_ghost(m, k, g1x - 2.0 * d2 * n2x, g1y - 2.0 * d2 * n2y, n1x, n1y, n2x, n2y);
        }
    }
}

/* Ghost velocities. For the rheology (mirror = 1) the ghost is a true
 * mirror image: normal component reversed, so ice converging on a coast
 * is compressed and ice leaving it is in divergence, where the
 * viscous-plastic stress relaxes. This pairs the ghosts' stress push with
 * the strain it does work against: with the normal velocity not reversed
 * for ice moving away, a compressed parcel kept its stress and the ghosts
 * kept pushing it off the coast, feeding kinetic energy in (a pack
 * bounced off a wall at 13 times its impact speed, bench plastic_wave).
 * For continuity (mirror = 0) a coast pushes but never pulls: ice moving
 * towards it (u.n < 0) sees the mirrored normal velocity, ice moving away
 * sees its own, so leaving a coast opens water behind it instead of
 * stretching the parcel. Tangentially: free slip keeps the component, no
 * slip reverses it. */
static inline void reflect_vec(double nx, double ny, int no_slip, int mirror, double *u,
                               double *v)
{
    if (nx == 0.0 && ny == 0.0)
        return;
    double un = *u * nx + *v * ny;
    double ut_x = *u - un * nx, ut_y = *v - un * ny;
    double gn = (mirror || un < 0.0) ? -un : un;
    if (no_slip) {
        ut_x = -ut_x;
        ut_y = -ut_y;
    }
    *u = ut_x + gn * nx;
    *v = ut_y + gn * ny;
}

void sph_ghost_velocity(sph_model *m, double *u, double *v, int mirror)
{
    size_t n = m->P->n;
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        double a = u[k], b = v[k];
        reflect_vec(m->ghost_nx[g], m->ghost_ny[g], m->prm.coast_no_slip, mirror, &a, &b);
        reflect_vec(m->ghost_n2x[g], m->ghost_n2y[g], m->prm.coast_no_slip, mirror, &a, &b);
        u[q] = a;
        v[q] = b;
    }
}

/* Ghost stress: the source's stress mirrored, R S R. An even mirror image
 * has no normal gradient at the coast, but ice resting on a coast carries
 * one: the normal momentum balance there (v.n = 0) gives
 * d(sigma_nn)/dn = -F.n, F the external force per area (air and water
 * stress, sea-surface tilt). So the ghost's sigma_nn is extrapolated
 * through the coast, sigma_nn(ghost) = sigma_nn(source) + 2 d F.n (d the
 * source's distance from the coast), the SPH counterpart of a hydrostatic
 * ghost pressure. Only where F presses the ice on the coast (F.n < 0): a
 * coast never pulls. Without it the first rows at a wall compressed until
 * their own stress made up the missing gradient (R300: 2.1 m instead of
 * 1.27 m at the wall). Corner ghosts (two walls) are mirrored only. */
/* The air stress on ghost g's source (the first part of ghost_normal_force:
 * wind and drag factor do not change within a step). */
static inline void ghost_air(const sph_model *m, size_t k, double *tax, double *tay)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double ua = P->ua[k], va = P->va[k], sa = hypot(ua, va);
    *tax = p->rho_a * p->Ca * sa * (ua * m->cos_air - va * m->sin_air);
    *tay = p->rho_a * p->Ca * sa * (ua * m->sin_air + va * m->cos_air);
}

static double ghost_normal_force(const sph_model *m, size_t k, double nx, double ny, double tax,
                                 double tay)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double rx = P->uw[k] - P->u[k], ry = P->vw[k] - P->v[k], sw = hypot(rx, ry);
    double twx = p->rho_w * p->Cw * sw * (rx * m->cos_water - ry * m->sin_water);
    double twy = p->rho_w * p->Cw * sw * (rx * m->sin_water + ry * m->cos_water);
    double dA = sph_drag_factor(m, k);
    double fx = dA * (tax + twx) - P->dens[k] * p->gravity * P->sshx[k];
    double fy = dA * (tay + twy) - P->dens[k] * p->gravity * P->sshy[k];
    return fx * nx + fy * ny;
}

void sph_ghost_air_setup(sph_model *m, double *air)
{
    for (size_t g = 0; g < m->ng; g++)
        ghost_air(m, (size_t)m->ghost_src[g], &air[2 * g], &air[2 * g + 1]);
}

void sph_ghost_stress_air(sph_model *m, const double *air)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        double a = P->s11[k], b = P->s12[k], c = P->s22[k];
        sph_ghost_stress_image(m->prm.coast_no_slip, m->ghost_nx[g], m->ghost_ny[g], m->ghost_n2x[g],
                               m->ghost_n2y[g], &a, &b, &c);
        double nx = m->ghost_nx[g], ny = m->ghost_ny[g];
        if (m->ghost_n2x[g] == 0.0 && m->ghost_n2y[g] == 0.0) {
            double tax, tay;
            if (air) {
                tax = air[2 * g];
                tay = air[2 * g + 1];
            } else {
                ghost_air(m, k, &tax, &tay);
            }
            double fn = ghost_normal_force(m, k, nx, ny, tax, tay);
            if (fn < 0.0) {
                double d = 0.5 * ((P->x[k] - P->x[q]) * nx + (P->y[k] - P->y[q]) * ny);
                /* at most the ice's own strength: a stress step the ice
                 * could not carry is no gradient of a resting state */
                double ds = fmax(2.0 * d * fn, -P->pres[k]);
                a += ds * nx * nx;
                b += ds * nx * ny;
                c += ds * ny * ny;
            }
        }
        P->s11[q] = a;
        P->s12[q] = b;
        P->s22[q] = c;
        P->dens[q] = P->dens[k];
        P->pres[q] = P->pres[k];
        P->conc[q] = P->conc[k];
        P->thick[q] = P->thick[k];
    }
}

void sph_ghost_stress(sph_model *m) { sph_ghost_stress_air(m, NULL); }

/* Keeps particles out of land; removes those leaving an open boundary. */
void sph_move_and_constrain(sph_model *m)
{
    sph_particles *P = m->P;
    double dt = m->prm.dt;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double x0 = P->x[k], y0 = P->y[k];
        double x1 = x0 + 0.5 * dt * (m->un[k] + P->u[k]);
        double y1 = y0 + 0.5 * dt * (m->vn[k] + P->v[k]);
        if (sph_is_land(m, x1, y1))
            blocked_move(m, P, k, x0, y0, &x1, &y1);
        P->x[k] = x1;
        P->y[k] = y1;
    }
}

/* The same move for one particle, its cell looked up once: where the
 * target cell is sea, that cell also says whether the particle left an
 * open boundary (outside_open's test); a blocked move tests again. */
int sph_move_one(sph_model *m, size_t k)
{
    sph_particles *P = m->P;
    const double dt = m->prm.dt;
    double x0 = P->x[k], y0 = P->y[k];
    double x1 = x0 + 0.5 * dt * (m->un[k] + P->u[k]);
    double y1 = y0 + 0.5 * dt * (m->vn[k] + P->v[k]);
    if (!m->has_mask) {
        P->x[k] = x1;
        P->y[k] = y1;
        return 0;
    }
    int i, j;
    int in = mask_cell(m, x1, y1, &i, &j);
    int land = in ? m->land[(size_t)j * m->mask.nx + i] != 0 : m->mask.closed_outside;
    if (land) {
        blocked_move(m, P, k, x0, y0, &x1, &y1);
        P->x[k] = x1;
        P->y[k] = y1;
        return outside_open(m, x1, y1);
    }
    P->x[k] = x1;
    P->y[k] = y1;
    /* not land: inside the mask's box, or outside an open one */
    return !in && !m->mask.closed_outside && isfinite(x1) && isfinite(y1);
}

/* Removes particles that left an open boundary (after the strain pass:
 * removal reorders the arrays the neighbour lists point into). */
void sph_remove_outflow(sph_model *m)
{
    sph_particles *P = m->P;
    if (!m->has_mask || m->mask.closed_outside)
        return; /* outside_open is 0 everywhere */
    /* the highest particle outside, on the threads (a max reduction: the
     * same whatever their count); the removals below, serially, from there
     * down: a removal moves the last particle, already looked at, into k */
    const size_t n = P->n;
    size_t top = 0; /* 1 + the highest index outside; 0: none */
#pragma omp parallel for schedule(static) reduction(max : top) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++)
        if (k + 1 > top && outside_open(m, P->x[k], P->y[k]))
            top = k + 1;
    for (size_t k = top; k-- > 0;) {
        if (outside_open(m, P->x[k], P->y[k])) {
            m->budget.outflow += P->mass[k];
            m->budget.snow_to_ocean += sph_particle_snow_mass(&m->prm.thermo, P, k);
            m->budget.removed_particles++;
            if (m->canonical && m->dd_owned[k]) { /* exact, owned only (core/dd.h) */
                sph_xsum_add(&m->dd_src[SPH_DD_SRC_OUTFLOW], P->mass[k]);
                sph_xsum_add(&m->dd_src[SPH_DD_SRC_SNOW_TO_OCEAN], sph_particle_snow_mass(&m->prm.thermo, P, k));
                sph_xsum_add(&m->dd_src[SPH_DD_SRC_REMOVED], 1.0);
            }
            /* its fluxes so far to the edge cell (by its owner only in
             * canonical mode: a halo copy's are its owner's) */
            if (sph_ocean_on(m) && (!m->canonical || m->dd_owned[k])) {
                if (sph_dd_ocean_stashes(m)) /* booked below in id order, every rank's */
                    sph_dd_ocean_stash_outflow(m, k);
                else
                    sph_ocean_take_particle(m, k);
            }
            sph_dd_remove(m, k);
        }
    }
    if (sph_dd_ocean_stashes(m)) /* on every rank, each step (a collective when decomposed) */
        sph_dd_ocean_book_outflow(m);
}
