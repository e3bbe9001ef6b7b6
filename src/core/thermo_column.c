/* Column thermodynamics: Bitz-Lipscomb material functions, surface energy
 * balance, the zero-layer (Semtner 1976) and multi-layer (Bitz & Lipscomb
 * 1999) columns. No I/O, no allocation in a step (the Brent solver is
 * allocated by sph_column_solver_create). */
#include "core/thermo.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_roots.h>
#include <math.h>
#include <stdlib.h>

#define SPH_STEFAN_BOLTZMANN 5.670374419e-8
#define SPH_KELVIN 273.15

double sph_snow_enthalpy(const sph_thermo_params *p, double T)
{
    return -p->rho_s * (p->L0 - p->c0 * (T < 0.0 ? T : 0.0));
}

/* Surface melt energy Em (J/m^2) spent on the snow of depth *hs and
 * temperature Tsnow first (each metre needs -q_s(Tsnow)): sets the snow
 * melted (m) and returns the energy left for the ice. */
static double melt_snow(const sph_thermo_params *p, double Em, double Tsnow, double *hs, double *snow_melt)
{
    double need = -sph_snow_enthalpy(p, Tsnow);
    double Esnow = need * *hs;
    if (Em <= Esnow) {
        *snow_melt = Em / need;
        *hs -= *snow_melt;
        return 0.0;
    }
    *snow_melt = *hs;
    *hs = 0.0;
    return Em - Esnow;
}

/* ---------------- Bitz & Lipscomb (1999) material functions -------- */

double sph_bl_salinity(const sph_thermo_params *p, double z)
{
    if (z <= 0.0)
        return 0.0;
    if (z > 1.0)
        z = 1.0;
    return 0.5 * p->salinity_max * (1.0 - cos(M_PI * pow(z, p->salinity_a / (z + p->salinity_b))));
}

double sph_bl_melting_temperature(const sph_thermo_params *p, double S) { return -p->mu * S; }

double sph_bl_heat_capacity(const sph_thermo_params *p, double S, double T)
{
    if (S <= 0.0 || T >= 0.0)
        return p->c0;
    return p->c0 + p->L0 * p->mu * S / (T * T);
}

/* k0 + beta S / T falls to zero at T = -beta S / k0 (-0.205 C for 3.2 ppt,
 * above Tm = -0.173 C): brine-rich ice near its melting point would
 * conduct with a negative conductivity. Floored as in CICE's
 * Bitz-Lipscomb column (ice_therm_bl99: kimin, 0.10 W/m/K, the minimum
 * conductivity of saline ice). */
#define SPH_BL_K_MIN 0.10

double sph_bl_conductivity(const sph_thermo_params *p, double S, double T)
{
    if (S <= 0.0 || T >= 0.0)
        return p->k0;
    double k = p->k0 + p->beta * S / T;
    return k > SPH_BL_K_MIN ? k : SPH_BL_K_MIN;
}

double sph_bl_enthalpy(const sph_thermo_params *p, double S, double T)
{
    double Tm = sph_bl_melting_temperature(p, S);
    if (T > Tm)
        T = Tm;
    if (S <= 0.0)
        return -p->rho_i * (p->L0 - p->c0 * T);
    return -p->rho_i * (p->c0 * (Tm - T) + p->L0 * (1.0 - Tm / T));
}

/* Inverse of q(S,T): q T / rho = -c0 Tm T + c0 T^2 - L0 T + L0 Tm, i.e.
 * c0 T^2 + B T + C = 0 with B = -(c0 Tm + L0 + q/rho), C = L0 Tm; the root
 * below Tm, written in the cancellation-free form for either sign of B. */
double sph_bl_temperature(const sph_thermo_params *p, double S, double q)
{
    double Tm = sph_bl_melting_temperature(p, S);
    double qr = q / p->rho_i;
    if (S <= 0.0) {
        double T = (qr + p->L0) / p->c0;
        return T < 0.0 ? T : 0.0;
    }
    if (qr >= 0.0)
        return Tm;
    double a = p->c0, B = -(p->c0 * Tm + p->L0 + qr), C = p->L0 * Tm;
    double disc = B * B - 4.0 * a * C;
    double T = B > 0.0 ? (-B - sqrt(disc)) / (2.0 * a) : 2.0 * C / (-B + sqrt(disc));
    return T < Tm ? T : Tm;
}

double sph_freezing_point(const sph_thermo_params *p) { return -p->mu * p->ocean_salinity; }

/* ---------------- tridiagonal solver -------------------------------- */

int sph_tridiag_solve(int n, const double *sub, const double *diag, const double *sup,
                      const double *rhs, double *x)
{
    double cp[SPH_MAX_LAYERS + 1];
    if (n < 1 || n > SPH_MAX_LAYERS + 1)
        return -1;
    double den = diag[0];
    if (den == 0.0)
        return -1;
    cp[0] = n > 1 ? sup[0] / den : 0.0;
    x[0] = rhs[0] / den;
    for (int i = 1; i < n; i++) {
        den = diag[i] - sub[i] * cp[i - 1];
        if (den == 0.0)
            return -1;
        cp[i] = i < n - 1 ? sup[i] / den : 0.0;
        x[i] = (rhs[i] - sub[i] * x[i - 1]) / den;
    }
    for (int i = n - 2; i >= 0; i--)
        x[i] -= cp[i] * x[i + 1];
    return 0;
}

/* ---------------- surface energy balance ---------------------------- */

/* Saturation vapour pressure, Pa (Magnus; WMO 2008 coefficients). */
static double esat_water(double T) { return 611.2 * exp(17.62 * T / (243.12 + T)); }
static double esat_ice(double T) { return 611.2 * exp(22.46 * T / (272.62 + T)); }
static double q_from_e(double e, double pres) { return 0.622 * e / (pres - 0.378 * e); }

void sph_column_forcing_default(sph_column_forcing *f)
{
    f->tair = NAN;
    f->qair = 0.0;
    f->wind = 0.0;
    f->swdn = 0.0;
    f->lwdn = 0.0;
    f->fsens = NAN;
    f->flat = NAN;
    f->albedo = NAN;
    f->sst = NAN;
    f->fw = NAN;
    f->tsurf_prescribed = NAN;
    f->snowfall = 0.0;
}

double sph_surface_albedo(const sph_thermo_params *p, const sph_column_forcing *f, double thick,
                          double snow, double tsurf)
{
    if (isfinite(f->albedo))
        return f->albedo;
    int melting = tsurf >= -0.01;
    if (snow > 0.0)
        return melting ? p->albedo_snow_melt : p->albedo_snow;
    double a = melting ? p->albedo_ice_melt : p->albedo_ice;
    /* Thin ice is darker (CICE): ramp to open water as atan(4h)/atan(4 ahmax). */
    if (p->albedo_thin_scale > 0.0 && thick < p->albedo_thin_scale) {
        double fh = atan(4.0 * thick) / atan(4.0 * p->albedo_thin_scale);
        a = p->albedo_water + (a - p->albedo_water) * fh;
    }
    return a;
}

double sph_surface_flux(const sph_thermo_params *p, const sph_column_forcing *f, double albedo,
                        double sw_fraction, double absorptivity, double emissivity, double Lv,
                        int over_water, double Ts)
{
    double Tk = Ts + SPH_KELVIN;
    double flux = (1.0 - albedo) * sw_fraction * f->swdn + absorptivity * f->lwdn -
                  emissivity * SPH_STEFAN_BOLTZMANN * Tk * Tk * Tk * Tk;
    double wind = f->wind > p->wind_min ? f->wind : p->wind_min;
    if (isfinite(f->fsens))
        flux += f->fsens;
    else
        flux += p->rho_a * p->cp_a * p->ch * wind * (f->tair - Ts);
    if (isfinite(f->flat)) {
        flux += f->flat;
    } else {
        double es = over_water ? esat_water(Ts) : esat_ice(Ts);
        flux += p->rho_a * Lv * p->ce * wind * (f->qair - q_from_e(es, p->air_pressure));
    }
    return flux;
}

double sph_open_water_flux(const sph_thermo_params *p, const sph_column_forcing *f)
{
    double Tf = sph_freezing_point(p);
    double Tw = isfinite(f->sst) && f->sst > Tf ? f->sst : Tf;
    /* A prescribed albedo is the ice surface's; open water keeps its own. */
    return sph_surface_flux(p, f, p->albedo_water, 1.0, p->emissivity_water, p->emissivity_water, p->Lv_water, 1, Tw);
}

/* ---------------- surface temperature (GSL Brent) ------------------- */

struct sph_column_solver {
    gsl_root_fsolver *brent;
};

sph_column_solver *sph_column_solver_create(void)
{
    sph_column_solver *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->brent = gsl_root_fsolver_alloc(gsl_root_fsolver_brent);
    if (!s->brent) {
        free(s);
        return NULL;
    }
    return s;
}

void sph_column_solver_free(sph_column_solver *s)
{
    if (!s)
        return;
    gsl_root_fsolver_free(s->brent);
    free(s);
}

/* Residual of the surface balance: atmospheric flux in minus conduction
 * into the column, the latter affine in Ts: a0 + a1 Ts. Decreasing in Ts
 * (emission, sensible and latent loss, and conduction all grow with Ts). */
typedef struct {
    const sph_thermo_params *p;
    const sph_column_forcing *f;
    double albedo, sw_fraction, a0, a1;
} surface_balance;

static double surface_residual(double Ts, void *arg)
{
    const surface_balance *b = arg;
    return sph_surface_flux(b->p, b->f, b->albedo, b->sw_fraction, b->p->lw_absorptivity, b->p->emissivity, b->p->Lv_ice, 0, Ts) -
           (b->a0 + b->a1 * Ts);
}

/* Solves surface_residual(Ts) = 0 for Ts <= Tmelt; at Tmelt with a positive
 * residual the surface melts with flux *fmelt. Returns SPH_STEP_RECOVERABLE
 * if no bracket is found down to -200 C (then Ts = -200 C). */
static int solve_surface(const sph_thermo_params *p, surface_balance *b, double Tmelt, double Tguess,
                         sph_column_solver *s, double *Ts, double *fmelt)
{
    double rhi = surface_residual(Tmelt, b);
    *fmelt = 0.0;
    if (rhi >= 0.0) {
        *Ts = Tmelt;
        *fmelt = rhi;
        return SPH_STEP_OK;
    }
    double lo = (isfinite(Tguess) && Tguess < Tmelt ? Tguess : Tmelt) - 10.0;
    double rlo = surface_residual(lo, b);
    while (rlo < 0.0 && lo > -200.0) {
        lo -= 30.0;
        rlo = surface_residual(lo, b);
    }
    if (rlo < 0.0) {
        *Ts = lo;
        return SPH_STEP_RECOVERABLE;
    }
    if (rlo == 0.0) {
        *Ts = lo;
        return SPH_STEP_OK;
    }
    gsl_function F = {surface_residual, b};
    gsl_root_fsolver_set(s->brent, &F, lo, Tmelt);
    double x = 0.5 * (lo + Tmelt);
    for (int it = 0; it < p->tsurf_max_iter; it++) {
        gsl_root_fsolver_iterate(s->brent);
        x = gsl_root_fsolver_root(s->brent);
        double xl = gsl_root_fsolver_x_lower(s->brent), xh = gsl_root_fsolver_x_upper(s->brent);
        if (gsl_root_test_interval(xl, xh, p->tsurf_tolerance, 0.0) == GSL_SUCCESS)
            break;
    }
    *Ts = x;
    return SPH_STEP_OK;
}

/* ---------------- column set-up ------------------------------------- */

static double layer_salinity(const sph_thermo_params *p, int k, int n)
{
    return sph_bl_salinity(p, (k + 0.5) / n);
}

/* Steady linear profile on c->nlayers layers: series conduction splits
 * Ts - Tf between snow and ice by their resistances. */
static void set_linear_profile(const sph_thermo_params *p, sph_column *c, double tsurf)
{
    double Tf = sph_freezing_point(p);
    int n = c->nlayers;
    double ri = c->thick / p->k0, rs = c->snow / p->k_s;
    double Ttop = ri + rs > 0.0 ? Tf + (tsurf - Tf) * ri / (ri + rs) : tsurf;
    for (int k = 0; k < n; k++) {
        double S = layer_salinity(p, k, n);
        double T = Ttop + (Tf - Ttop) * (k + 0.5) / n;
        double Tm = sph_bl_melting_temperature(p, S);
        if (T > Tm)
            T = Tm;
        c->enth[k] = sph_bl_enthalpy(p, S, T);
    }
    /* the snow's mid-depth temperature where it holds heat, else 0 */
    double Tsn = 0.5 * (tsurf + Ttop);
    c->tsnow = p->snow_heat_capacity && c->snow > 0.0 && Tsn < 0.0 ? Tsn : 0.0;
}

void sph_column_init(const sph_thermo_params *p, sph_column *c, double thick, double snow, double tsurf)
{
    c->thick = thick;
    c->snow = snow > 0.0 ? snow : 0.0;
    c->tsurf = tsurf;
    c->nlayers = p->nlayers;
    for (int k = 0; k < SPH_MAX_LAYERS; k++)
        c->enth[k] = 0.0;
    set_linear_profile(p, c, tsurf);
}

double sph_column_energy(const sph_thermo_params *p, const sph_column *c)
{
    double e = 0.0, dz = c->thick / c->nlayers;
    for (int k = 0; k < c->nlayers; k++)
        e += c->enth[k] * dz;
    return e + sph_snow_enthalpy(p, c->tsnow) * c->snow;
}

static void result_clear(sph_column_result *r)
{
    r->growth = r->melt_top = r->melt_bottom = r->snow_melt = 0.0;
    r->albedo = r->fatm = r->fmelt = r->fcond_top = r->fcond_bottom = r->focean = 0.0;
    r->snow_to_ice = r->snow_ice = 0.0;
    r->energy_to_ocean = 0.0;
    r->sw_base = 0.0;
    r->melted_out = 0;
    r->iterations = 0;
}

static double ocean_flux(const sph_thermo_params *p, const sph_column_forcing *f)
{
    return isfinite(f->fw) ? f->fw : p->fw_default;
}

/* ---------------- zero-layer (Semtner 1976) ------------------------- */

/* Linear profile, no heat capacity: the conductive flux is (Ts - Tf) / R
 * with R = h/k + hs/ks. Basal growth integrates
 *   rho L_b dh/dt = (Tf - Ts) / R(h) - F_w
 * with R evaluated at the mean thickness (h + h')/2. For fixed Ts, no snow
 * and F_w = 0 that is h'^2 = h^2 + 2 k (Tf - Ts) dt / (rho L_b): Stefan's law
 * exactly, whatever the step; h = k (Tf - Ts) / F_w is a fixed point. */
int sph_column_step_zero_layer(const sph_thermo_params *p, sph_column *c, const sph_column_forcing *f,
                               double dt, sph_column_solver *s, sph_column_result *r)
{
    result_clear(r);
    double Tf = sph_freezing_point(p);
    double Tmelt = 0.0; /* snow and the (fresh) ice surface */
    double h = c->thick, hs = c->snow + (f->snowfall > 0.0 ? f->snowfall * dt : 0.0);
    double Lb = -sph_bl_enthalpy(p, p->salinity_max, Tf) / p->rho_i; /* new ice at the base */
    c->tsnow = 0.0; /* no heat capacity: the snow holds its latent heat only */
    double Ltop = p->L0;                                             /* surface ice is fresh */
    double Fw = ocean_flux(p, f);
    int rc = SPH_STEP_OK;

    double G = 1.0 / (h / p->k0 + hs / p->k_s);
    double albedo = sph_surface_albedo(p, f, h, hs, c->tsurf);
    surface_balance b = {p, f, albedo, 1.0, -G * Tf, G};
    double Ts, fmelt = 0.0;
    if (isfinite(f->tsurf_prescribed)) {
        Ts = f->tsurf_prescribed;
    } else {
        rc = solve_surface(p, &b, Tmelt, c->tsurf, s, &Ts, &fmelt);
    }
    r->albedo = albedo;
    r->fatm = sph_surface_flux(p, f, albedo, 1.0, p->lw_absorptivity, p->emissivity, p->Lv_ice, 0, Ts);
    r->fmelt = fmelt;
    r->fcond_top = G * (Ts - Tf);
    r->focean = Fw;

    /* Surface melt: snow first, then ice. */
    double Em = fmelt * dt;
    if (Em > 0.0) {
        Em = melt_snow(p, Em, 0.0, &hs, &r->snow_melt);
        double dh = Em / (p->rho_i * Ltop);
        if (dh >= h) {
            r->melt_top = h;
            r->energy_to_ocean = (dh - h) * p->rho_i * Ltop;
            h = 0.0;
        } else {
            r->melt_top = dh;
            h -= dh;
        }
    }

    if (h > 0.0) {
        /* Quadratic for the new thickness x:
         * alpha (x - h)(r0 + x/(2k)) + dt Fw (r0 + x/(2k)) - dt (Tf - Ts) = 0. */
        double alpha = p->rho_i * Lb, k2 = 2.0 * p->k0;
        double r0 = h / k2 + hs / p->k_s;
        double a2 = alpha / k2;
        double a1 = alpha * (r0 - h / k2) + dt * Fw / k2;
        double a0 = -alpha * h * r0 + dt * Fw * r0 - dt * (Tf - Ts);
        double disc = a1 * a1 - 4.0 * a2 * a0;
        double h1 = h, x = -1.0;
        if (disc >= 0.0)
            x = a1 <= 0.0 ? (-a1 + sqrt(disc)) / (2.0 * a2) : -2.0 * a0 / (a1 + sqrt(disc));
        if (!(x > 0.0)) {
            /* The base melts through: the ocean supplies the rest. */
            r->melt_bottom = h;
            h = 0.0;
        } else if (x >= h) {
            r->growth = x - h;
            h = x;
        } else {
            r->melt_bottom = h - x;
            h = x;
        }
        r->fcond_bottom = (Ts - Tf) / (0.5 * (h1 + h) / p->k0 + hs / p->k_s);
    }
    if (h < p->min_thickness) {
        r->melt_bottom += h;
        h = 0.0;
    }
    if (h <= 0.0) {
        r->melted_out = 1;
        r->energy_to_ocean -= p->rho_s * p->L0 * hs;
        hs = 0.0;
        c->thick = 0.0;
        c->snow = 0.0;
        c->tsurf = Tf;
        for (int k = 0; k < c->nlayers; k++)
            c->enth[k] = 0.0;
        return rc;
    }
    /* Keep the multi-layer state consistent (linear profile) so that a
     * particle may switch models without a jump in temperature. */
    c->thick = h;
    c->snow = hs;
    c->tsurf = Ts;
    set_linear_profile(p, c, Ts > Tmelt ? Tmelt : Ts);
    if (p->snow_ice)
        sph_column_snow_ice(p, c, r);
    return rc;
}

/* ---------------- multi-layer (Bitz & Lipscomb 1999) ---------------- */

/* One segment of the column being rebuilt after melt and growth. */
typedef struct {
    double dz, q;
} segment;

/* Melts segment s with energy E (J/m^2): the whole segment when E covers
 * its enthalpy, else the part E pays for. Adds the melted thickness to
 * *melt and returns the energy left. */
static double melt_segment(segment *s, double E, double *melt)
{
    double need = -s->q * s->dz;
    if (E >= need) {
        *melt += s->dz;
        s->dz = 0.0;
        return E - need;
    }
    double d = E / -s->q;
    s->dz -= d;
    *melt += d;
    return 0.0;
}

/* Conservative remap of segments (top first) onto n equal layers. */
static void remap_layers(int nseg, const segment *seg, double h, int n, double *enth)
{
    double dz = h / n;
    int j = 0;
    double used = 0.0; /* thickness of seg[j] already assigned */
    for (int k = 0; k < n; k++) {
        double need = dz, e = 0.0;
        while (need > 0.0 && j < nseg) {
            double avail = seg[j].dz - used;
            double take = avail < need ? avail : need;
            e += take * seg[j].q;
            need -= take;
            used += take;
            if (seg[j].dz - used <= 0.0) {
                j++;
                used = 0.0;
            }
        }
        /* round-off shortfall at the last layer takes the last segment's q */
        if (need > 0.0 && nseg > 0)
            e += need * seg[nseg - 1].q;
        enth[k] = e / dz;
    }
}

int sph_column_step_multi_layer(const sph_thermo_params *p, sph_column *c, const sph_column_forcing *f,
                                double dt, sph_column_solver *s, sph_column_result *r)
{
    result_clear(r);
    const int n = c->nlayers;
    const double Tf = sph_freezing_point(p);
    const double Tmelt = 0.0;
    const double h = c->thick;
    const double hs0 = c->snow > 0.0 ? c->snow : 0.0;
    double hs = hs0 + (f->snowfall > 0.0 ? f->snowfall * dt : 0.0);
    const double dz = h / n;
    /* Snow enthalpy: new snow arrives at 0 deg C (q_s linear in T, so the
     * mixture's temperature is the depth-weighted mean); without
     * snow_heat_capacity it stays at 0 (latent heat only). */
    double Tsn = p->snow_heat_capacity && hs > 0.0 && c->tsnow < 0.0 ? c->tsnow * hs0 / hs : 0.0;
    const int sl = p->snow_heat_capacity && hs >= SPH_SNOW_LAYER_MIN; /* snow layer solved */
    const int N = n + sl; /* unknowns: [snow,] ice layers */
    const double Fw = ocean_flux(p, f);
    int rc = SPH_STEP_OK;

    double S[SPH_MAX_LAYERS], Tm[SPH_MAX_LAYERS], Told[SPH_MAX_LAYERS], T[SPH_MAX_LAYERS];
    double qold[SPH_MAX_LAYERS], I[SPH_MAX_LAYERS];
    double Cap[SPH_MAX_LAYERS], Kl[SPH_MAX_LAYERS], Gint[SPH_MAX_LAYERS + 2];
    double sub[SPH_MAX_LAYERS + 1], dia[SPH_MAX_LAYERS + 1], sup[SPH_MAX_LAYERS + 1];
    double rhs[SPH_MAX_LAYERS + 1], Tp[SPH_MAX_LAYERS + 1], Th[SPH_MAX_LAYERS + 1];
    double X[SPH_MAX_LAYERS + 1]; /* the unknowns: X[0] the snow when sl, then T */

    for (int k = 0; k < n; k++) {
        S[k] = layer_salinity(p, k, n);
        Tm[k] = sph_bl_melting_temperature(p, S[k]);
        qold[k] = c->enth[k];
        Told[k] = sph_bl_temperature(p, S[k], qold[k]);
        T[k] = Told[k];
    }
    const double qsold = sph_snow_enthalpy(p, Tsn);
    if (sl)
        X[0] = Tsn;
    for (int k = 0; k < n; k++)
        X[k + sl] = T[k];

    /* Shortwave: a fraction i0 of the absorbed SW penetrates bare ice and
     * decays as exp(-gamma z); what reaches the base is absorbed there. */
    double albedo = sph_surface_albedo(p, f, h, hs, c->tsurf);
    double i0 = hs > 0.0 ? 0.0 : p->sw_pen_frac;
    double swabs = (1.0 - albedo) * f->swdn;
    double Ipen = i0 * swabs, Ibase = 0.0;
    for (int k = 0; k < n; k++)
        I[k] = Ipen * (exp(-p->sw_extinction * k * dz) - exp(-p->sw_extinction * (k + 1) * dz));
    Ibase = Ipen * exp(-p->sw_extinction * h);

    double Ts = isfinite(c->tsurf) ? c->tsurf : Tmelt;
    double fmelt = 0.0;
    int prescribed = isfinite(f->tsurf_prescribed);
    if (prescribed)
        Ts = f->tsurf_prescribed;
    surface_balance b = {p, f, albedo, 1.0 - i0, 0.0, 0.0};

    int it;
    for (it = 0;; it++) { /* at least one solve */
        /* c and K from the current iterate; c as the secant of q between the
         * old and the current temperature, so that at convergence
         * Cap (T - Told) = q(T) - q(Told) exactly. */
        for (int k = 0; k < n; k++) {
            double Te = T[k] < Tm[k] ? T[k] : Tm[k];
            if (fabs(Te - Told[k]) > 1e-10)
                Cap[k] = (sph_bl_enthalpy(p, S[k], Te) - qold[k]) / (Te - Told[k]);
            else
                Cap[k] = p->rho_i * sph_bl_heat_capacity(p, S[k], Told[k]);
            Kl[k] = sph_bl_conductivity(p, S[k], Te);
        }
        /* Gint[j]: conductance above unknown j (j = 0: from the surface; the
         * snow in series with half the first layer when it is not solved);
         * Gint[N]: between the last layer centre and the base at Tf. */
        if (sl) {
            Gint[0] = 2.0 * p->k_s / hs;
            Gint[1] = 1.0 / (0.5 * hs / p->k_s + 0.5 * dz / Kl[0]);
        } else {
            Gint[0] = 1.0 / (hs / p->k_s + 0.5 * dz / Kl[0]);
        }
        for (int k = 1; k < n; k++)
            Gint[k + sl] = 1.0 / (0.5 * dz / Kl[k - 1] + 0.5 * dz / Kl[k]);
        Gint[N] = 2.0 * Kl[n - 1] / dz;
        for (int j = 0; j < N; j++) {
            int k = j - sl; /* ice layer, or -1 for the snow */
            double m = k < 0 ? p->rho_s * p->c0 * hs / dt : Cap[k] * dz / dt;
            sub[j] = -Gint[j];
            sup[j] = -Gint[j + 1];
            dia[j] = m + Gint[j] + Gint[j + 1];
            rhs[j] = (k < 0 ? m * Tsn : m * Told[k] + I[k]) + (j == N - 1 ? Gint[N] * Tf : 0.0);
        }
        sub[0] = 0.0; /* the surface enters through Ts, affinely */
        if (sph_tridiag_solve(N, sub, dia, sup, rhs, Tp) != 0)
            return SPH_STEP_FATAL;
        for (int j = 0; j < N; j++)
            rhs[j] = j == 0 ? Gint[0] : 0.0;
        if (sph_tridiag_solve(N, sub, dia, sup, rhs, Th) != 0)
            return SPH_STEP_FATAL;
        /* T = Tp + Ts Th; top conduction G0 (Ts - T0) = a0 + a1 Ts. */
        if (!prescribed) {
            b.a0 = -Gint[0] * Tp[0];
            b.a1 = Gint[0] * (1.0 - Th[0]);
            rc = solve_surface(p, &b, Tmelt, Ts, s, &Ts, &fmelt);
        }
        double dmax = 0.0;
        for (int j = 0; j < N; j++) {
            double Tn = Tp[j] + Ts * Th[j];
            double d = fabs(Tn - X[j]);
            if (d > dmax)
                dmax = d;
            X[j] = Tn;
        }
        for (int k = 0; k < n; k++)
            T[k] = X[k + sl];
        if (dmax < p->picard_tolerance || it + 1 >= p->picard_max_iter)
            break;
    }
    r->iterations = it + 1;

    /* Flux-form enthalpy update with the conductances and temperatures of
     * the last solve: the sum telescopes, so sum dE = (Ftop + sum I - Fbot) dt. */
    double Fc[SPH_MAX_LAYERS + 2];
    Fc[0] = Gint[0] * (Ts - X[0]);
    for (int j = 1; j < N; j++)
        Fc[j] = Gint[j] * (X[j - 1] - X[j]);
    Fc[N] = Gint[N] * (X[N - 1] - Tf);
    double qnew[SPH_MAX_LAYERS];
    double Eexcess = 0.0; /* energy above brine (q > 0) or above melting snow melts the surface */
    if (sl) {
        double qs = qsold + dt * (Fc[0] - Fc[1]) / hs, qs0 = sph_snow_enthalpy(p, 0.0);
        if (qs > qs0) {
            Eexcess += (qs - qs0) * hs;
            qs = qs0;
        }
        Tsn = (qs / p->rho_s + p->L0) / p->c0;
        if (Tsn > 0.0) /* round-off */
            Tsn = 0.0;
    }
    for (int k = 0; k < n; k++) {
        qnew[k] = qold[k] + dt * (Fc[k + sl] - Fc[k + sl + 1] + I[k]) / dz;
        if (qnew[k] > 0.0) {
            Eexcess += qnew[k] * dz;
            qnew[k] = 0.0;
        }
    }
    r->albedo = albedo;
    r->fatm = sph_surface_flux(p, f, albedo, 1.0 - i0, p->lw_absorptivity, p->emissivity, p->Lv_ice, 0, Ts) + Ipen;
    r->fmelt = fmelt;
    r->fcond_top = Fc[0];
    r->fcond_bottom = Fc[N];
    r->focean = Fw;
    r->sw_base = Ibase;

    /* Segments of the old grid, trimmed by melt, plus new ice at the base. */
    segment seg[SPH_MAX_LAYERS + 1];
    int nseg = n;
    for (int k = 0; k < n; k++) {
        seg[k].dz = dz;
        seg[k].q = qnew[k];
    }
    int top = 0; /* first segment with ice left */

    /* Base: ocean flux plus SW reaching the base plus conduction from above. */
    double Eb = (Fw + Ibase + Fc[N]) * dt;
    if (Eb < 0.0) {
        double qb = sph_bl_enthalpy(p, p->salinity_max, Tf);
        seg[nseg].dz = Eb / qb;
        seg[nseg].q = qb;
        r->growth = seg[nseg].dz;
        nseg++;
    } else {
        double E = Eb;
        for (int k = nseg - 1; k >= top && E > 0.0; k--)
            E = melt_segment(&seg[k], E, &r->melt_bottom);
        r->energy_to_ocean += E;
    }

    /* Surface: melt flux (and any internal excess) on snow, then ice. */
    double Em = fmelt * dt + Eexcess;
    if (Em > 0.0) {
        Em = melt_snow(p, Em, Tsn, &hs, &r->snow_melt);
        for (int k = 0; k < nseg && Em > 0.0; k++)
            if (seg[k].dz > 0.0)
                Em = melt_segment(&seg[k], Em, &r->melt_top);
        r->energy_to_ocean += Em;
    }

    double hnew = 0.0;
    for (int k = 0; k < nseg; k++)
        hnew += seg[k].dz;
    c->tsurf = Ts;
    if (hnew < p->min_thickness) {
        /* Remnants go to the ocean with their (negative) energy. */
        double e = 0.0;
        for (int k = 0; k < nseg; k++)
            e += seg[k].dz * seg[k].q;
        r->energy_to_ocean += e + sph_snow_enthalpy(p, Tsn) * hs;
        r->melt_bottom += hnew;
        r->melted_out = 1;
        c->thick = 0.0;
        c->snow = 0.0;
        c->tsnow = 0.0;
        c->tsurf = Tf;
        for (int k = 0; k < n; k++)
            c->enth[k] = 0.0;
        return rc;
    }
    remap_layers(nseg, seg, hnew, n, c->enth);
    c->thick = hnew;
    c->snow = hs;
    c->tsnow = hs > 0.0 ? Tsn : 0.0;
    if (p->snow_ice)
        sph_column_snow_ice(p, c, r);
    return rc;
}

/* ---------------- snow: rain/snow split, snow-ice -------------------- */

double sph_snow_fraction(const sph_thermo_params *p, double tair)
{
    if (!isfinite(tair))
        return 0.0;
    if (tair <= p->snow_t_snow)
        return 1.0;
    if (tair >= p->snow_t_rain)
        return 0.0;
    return (p->snow_t_rain - tair) / (p->snow_t_rain - p->snow_t_snow);
}

int sph_column_snow_ice(const sph_thermo_params *p, sph_column *c, sph_column_result *r)
{
    double h = c->thick, hs = c->snow;
    if (!(h > 0.0) || !(hs > 0.0))
        return 0;
    double excess = p->rho_s * hs - (p->rho_w - p->rho_i) * h; /* kg/m^2 below the waterline */
    if (!(excess > 0.0))
        return 0;
    double dh = excess / p->rho_w;
    double ds = p->rho_i * dh / p->rho_s;
    if (ds > hs) { /* only when rho_i > rho_w: not in the parameter ranges */
        ds = hs;
        dh = p->rho_s * ds / p->rho_i;
    }
    /* The zero-layer keeps the linear profile; the multi-layer column
     * gains a top segment of q = q_s(tsnow) ds / dh, remapped. */
    int n = c->nlayers;
    segment seg[SPH_MAX_LAYERS + 1];
    seg[0].dz = dh;
    seg[0].q = sph_snow_enthalpy(p, c->tsnow) * ds / dh;
    for (int k = 0; k < n; k++) {
        seg[k + 1].dz = h / n;
        seg[k + 1].q = c->enth[k];
    }
    remap_layers(n + 1, seg, h + dh, n, c->enth);
    c->thick = h + dh;
    c->snow = hs - ds;
    if (!(c->snow > 0.0))
        c->tsnow = 0.0;
    if (r) {
        r->snow_to_ice += ds;
        r->snow_ice += dh;
    }
    return 1;
}
