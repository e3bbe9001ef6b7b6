/* Bonded-particle discrete elements for ice against a structure (the second
 * seed, Ji, Li & Liu 2012, section 3.2; docs/dem.md).
 *
 * Spherical 3-D particles (position, velocity, angular velocity, radius,
 * mass, moment of inertia 2/5 m r^2). Between two particles in contact:
 * a linear spring-dashpot normal force K_n delta + C_n v_n and an
 * incremental tangential spring K_s with dashpot C_s, capped by
 * Mohr-Coulomb friction mu |F_n| (the seed's Fig. 18). C_n and C_s come
 * from a restitution coefficient e: zeta = -ln e / sqrt(pi^2 + ln^2 e),
 * C = 2 zeta sqrt(m* K), m* = m_i m_j / (m_i + m_j). Between two frozen
 * particles: a parallel bond (Potyondy & Cundall 2004), an elastic disc of
 * radius R = lambda min(r_i, r_j) carrying the normal force, shear force,
 * twisting and bending moments by increments
 *   dF_n = k_n A dU_n, dF_s = k_s A dU_s, dM_n = k_s J dth_n, dM_s = k_n I dth_s
 * (k_n = E_b / (r_i + r_j) per unit area, k_s = k_n * bond_shear_ratio;
 * A = pi R^2, I = pi R^4 / 4, J = pi R^4 / 2), broken by the seed's eq. 9:
 *   sigma = T / A + |M_s| R / I >= sigma_t  or  tau = |F_s| / A + |M_n| R / J >= tau_c
 * (T the tensile normal force). An intact bond replaces the contact law
 * between its two particles; once broken they interact by contact only.
 *
 * Water: buoyancy rho_w g V_sub (spherical cap under z = 0) and a quadratic
 * drag 0.5 rho_w C_d pi r^2 |u - v| (u - v) scaled by the submerged
 * fraction. Gravity along -z.
 *
 * The structure is a rigid body moving horizontally as a damped oscillator
 * m x'' + c x' + k x = F_ice (c = 2 zeta sqrt(k m)): a vertical cylinder
 * or an upward-breaking cone (angle from the horizontal, waterline
 * diameter, neck diameter, a vertical neck above). Particle-structure
 * contact uses the particle-particle law with the particle's own mass.
 *
 * Time stepping: central differences (leapfrog, the scheme of PFC and of
 * the seed's references): v(n+1/2) = v(n-1/2) + a(n) dt, x(n+1) = x(n) +
 * v(n+1/2) dt. The stable step of one spring is 2 sqrt(m/K);
 * dem_dt_critical() bounds the stiffest mode of a sphere with 12 springs
 * (translation and rotation, dashpots included, see dem.c), and dem_step()
 * refuses a step beyond dt_safety * dt_critical
 * with SPH_FAULT_TIMESTEP.
 *
 * Determinism: each particle gathers its own contact forces (pairs are
 * evaluated from both sides with bit-identical antisymmetric results);
 * bonds are updated once per bond and gathered per particle in a fixed
 * order; the structure's load is summed in index order. No atomics.
 *
 * Memory: everything is allocated by dem_create; dem_step allocates
 * nothing. */
#ifndef SPHICE_CORE_DEM_H
#define SPHICE_CORE_DEM_H

#include <stddef.h>
#include "core/status.h"

typedef struct dem_params {
    double density;          /* particle density, kg m-3 (ice 900) */
    double kn;               /* contact normal stiffness K_n, N m-1 */
    double ks_ratio;         /* K_s / K_n */
    double restitution;      /* e in (0, 1] */
    double friction;         /* mu between particles and on the structure */
    double bond_modulus;     /* E_b, Pa */
    double bond_shear_ratio; /* k_s / k_n of bonds */
    double bond_radius;      /* lambda: bond radius / smaller particle radius */
    double bond_tensile;     /* sigma_t, Pa */
    double bond_shear;       /* tau_c, Pa */
    double water_density;    /* rho_w, kg m-3; 0: no water */
    double gravity;          /* g, m s-2 (0: none) */
    double drag;             /* C_d of a sphere */
    double current[3];       /* water velocity, m s-1 */
    double local_damping;    /* alpha of PFC's local damping (quasi-static tests; 0 dynamic) */
    double dt_safety;        /* a step may be at most dt_safety * dt_critical (<= 1) */
    int max_contacts;        /* contact slots per particle */
} dem_params;

/* Ice defaults (docs/dem.md gives the sources). */
void dem_params_default(dem_params *p);

enum { DEM_STRUCT_NONE = 0, DEM_STRUCT_CYLINDER = 1, DEM_STRUCT_CONE = 2 };

typedef struct dem_structure {
    int kind;                 /* DEM_STRUCT_* */
    double x0, y0;            /* axis at rest, m */
    double diameter;          /* cylinder: diameter; cone: waterline diameter, m */
    double cone_angle;        /* cone: angle from the horizontal, degrees (0, 90) */
    double neck_diameter;     /* cone: top (neck) diameter, m, < diameter */
    double z_waterline;       /* height where the cone has `diameter`, m */
    double mass;              /* kg; 0: fixed */
    double stiffness;         /* N m-1 */
    double damping_ratio;     /* zeta */
    /* state (horizontal) */
    double ux, uy, vx, vy, ax, ay;
    double fx, fy, fz;        /* ice load of the last step, N (on the structure) */
} dem_structure;

/* Particle flags */
/* DEM_FIX_TRANSLATION: the velocity is prescribed (kept); DEM_FIX_Z: only
 * its vertical component (a roller support); DEM_FIX_X, DEM_FIX_Y: only
 * that horizontal component (DEM_FIX_Y alone: a side held laterally, free
 * along the drift and vertically); DEM_FIX_ROTATION: the angular velocity
 * is kept. */
enum { DEM_FIX_TRANSLATION = 1, DEM_FIX_ROTATION = 2, DEM_FIX_Z = 4, DEM_FIX_X = 8, DEM_FIX_Y = 16 };

typedef struct dem_bond {
    int i, j;
    int broken;                 /* 0 intact, 1 tension, 2 shear */
    double radius, kn, ks;      /* R, k_n, k_s */
    double fn;                  /* normal force, tension positive, N */
    double fs[3];               /* shear force on i, N */
    double mn;                  /* twisting moment on i about n, N m */
    double ms[3];               /* bending moment on i, N m */
    double sigma_t, tau_c;      /* strengths of this bond, Pa */
    /* contributions of the last update: force on i (j gets minus), torques */
    double f_i[3], t_i[3], t_j[3];
} dem_bond;

typedef struct dem {
    dem_params p;
    size_t n, cap;
    size_t nbonds, cap_bonds;
    double *x, *y, *z;          /* positions, m */
    double *vx, *vy, *vz;       /* velocities (half step), m s-1 */
    double *wx, *wy, *wz;       /* angular velocities, s-1 */
    double *r, *m, *inertia;    /* radius, mass, moment of inertia */
    double *fx, *fy, *fz;       /* total force of the last step */
    double *tx, *ty, *tz;       /* total torque of the last step */
    double *ext;                /* [3 n] external force (tests, loads) */
    int *flags;                 /* DEM_FIX_* */
    /* contacts: per particle max_contacts slots, double-buffered */
    int *c_id[2];               /* partner index or -1 */
    double *c_us[2];            /* [3 per slot] tangential spring force, N */
    int *c_n[2];                /* slots used */
    int cur;                    /* which buffer holds the current contacts */
    /* structure contact: one tangential history per particle */
    double *s_fs;               /* [3 n] */
    double *s_f;                /* [3 n] force of each particle on the structure */
    /* bonds, and per particle the bonds it belongs to (CSR) */
    dem_bond *bonds;
    int *b_start, *b_list;      /* [cap + 1], [2 cap_bonds] */
    int bonds_indexed;
    double dt_crit;             /* cached dem_dt_critical for (dt_n, dt_nbonds) */
    size_t dt_n, dt_nbonds;
    void *grid;                 /* the SPH core's cell grid (sph_nbr) */
    dem_structure s;
    long step;
    double time;
    long contacts;              /* contacts of the last step (pairs counted twice) */
    long bonds_intact;
    long bonds_broken_tension, bonds_broken_shear;
} dem;

dem *dem_create(size_t cap_particles, size_t cap_bonds, const dem_params *p);
void dem_free(dem *d);

/* Adds a particle; returns its index or -1 when full / invalid radius. */
long dem_add_particle(dem *d, double x, double y, double z, double r);
/* Bonds i and j (at their present distance) with the default strengths;
 * returns the bond index or -1. */
long dem_add_bond(dem *d, long i, long j);
/* Bonds every pair whose gap is below tol * (r_i + r_j); returns the count. */
long dem_bond_touching(dem *d, double tol);

/* The stable step (the 2 sqrt(m/K) of the stiffest mode, see dem.c). */
double dem_dt_critical(const dem *d);

/* Checks the parameters and the structure: 0, or SPH_STEP_FATAL with st. */
int dem_check(const dem *d, sph_status *st);

/* One step of dt. Refuses (SPH_STEP_RECOVERABLE, SPH_FAULT_TIMESTEP) a
 * step beyond dt_safety * dt_critical, SPH_FAULT_CAPACITY when a contact
 * list overflows, SPH_FAULT_NONFINITE on a NaN. */
int dem_step(dem *d, double dt, sph_status *st);

/* Sets the velocity of particle i (driven particles keep it when fixed). */
void dem_set_velocity(dem *d, long i, double vx, double vy, double vz);

/* A level sheet of nz close-packed (hcp, ABA...) layers of spheres of
 * radius r: rows along x of nx spheres (spacing 2r), ny rows (spacing
 * sqrt(3) r), layer spacing 2r sqrt(2/3), so thickness 2r + (nz - 1) 2r
 * sqrt(2/3) (3 layers of 0.1 m spheres: 0.263 m). Floating at the level
 * of its density (bottom at -draft); touching spheres bonded; all moving
 * at (u, v). Returns the first index, or -1 if it does not fit. */
long dem_add_sheet_hcp(dem *d, double x0, double y0, int nx, int ny, int nz, double r, double u,
                       double v);

/* A level sheet of bonded particles on a simple cubic lattice: nx * ny
 * columns of spacing 2r starting at (x0, y0), nz layers of spacing 2r
 * centred on the floating level for thickness nz * 2r; all moving at
 * (u, v). Returns the first index, or -1 if it does not fit. */
long dem_add_sheet(dem *d, double x0, double y0, int nx, int ny, int nz, double r,
                   double u, double v);

/* Mean, max and standard deviation of a series of n samples (O(n): any
 * length). */
void dem_load_moments(const double *f, size_t n, double *mean, double *max, double *std);

/* Load statistics over a series of n samples spaced dt: mean, max, std
 * and the dominant frequency (largest DFT amplitude above zero, Hz). The
 * DFT is a direct sum, O(n^2): give it block means (a few thousand
 * samples), not a contact-step series (hundreds of thousands of steps
 * take hours); dem_load_moments for the moments of a long series. */
void dem_load_stats(const double *f, size_t n, double dt, double *mean, double *max,
                    double *std, double *freq);

/* Cheap models (src/core/dem/loads.c). */

/* ISO 19906 (2010) A.8.2.4.3 global crushing pressure, Pa:
 * p_G = C_R (h/h1)^n (w/h)^m, h1 = 1 m, n = -0.5 + h/5 (h < 1 m) else -0.3,
 * m = -0.16. Valid for w/h > 2 (returns NAN otherwise or for h, w <= 0). */
double dem_iso_pressure(double c_r, double h, double w);
/* F = p_G w h, N. */
double dem_iso_force(double c_r, double h, double w);

/* Ralston's (1977) bending-failure load of level ice on an upward-breaking
 * cone, in the form of IEC 61400-3 ed. 1 Annex E as implemented by the
 * IceFloe module of NREL's OpenFAST (modules/icefloe/src/icefloe/
 * IceFlexIEC.f90, DNV KEMA 2014; docs/dem.md gives the equations):
 *   H = H_B + H_R,
 *   H_B = sigma_f h^2 / 3 * tan(a) / (1 - mu g) * [G (x-1)(x+2) + (1 + Y x ln x)/(x-1)],
 *   G = rho_i g_0 D^2 / (4 sigma_f h), x = 1 + (3 G + Y/2)^-1/2, Y = 2.711 (Tresca),
 *   g = (sin a + a / cos a) / (2 mu a cos a + pi/2 sin^2 a),
 *   H_R = W [tan a + mu (E - f g cos a)] / (1 - mu g),
 *   W = rho_i g_0 h_r (D^2 - D_T^2) / (4 cos a), f = mu K cos a + sin a,
 * K, E the complete elliptic integrals of modulus sin a. The vertical load
 * V = H / xi, xi = (sin a + mu cos a)/(cos a - mu sin a), is the 2-D
 * contact statics of the cone face (Croasdale's xi), not Ralston's own
 * vertical coefficients (not found in the sources searched).
 * Range (IceFloe's input limits): a in [20, 70] degrees, mu in
 * [0, min(tan a, cot a) - 0.01], 1 - mu g > 0; D > D_T >= 0. */
typedef struct dem_cone_ice {
    double flexural_strength; /* sigma_f, Pa */
    double thickness;         /* h, m */
    double rideup_thickness;  /* h_r, m */
    double ice_density;       /* rho_i, kg m-3 */
    double friction;          /* mu, ice on the cone */
    double angle;             /* a, degrees from the horizontal */
    double diameter;          /* D, waterline, m */
    double top_diameter;      /* D_T, where the ride-up ends (neck), m */
} dem_cone_ice;

typedef struct dem_cone_load {
    double h, v;              /* horizontal and vertical load, N */
    double h_break, h_rideup; /* H_B and H_R, N */
    double g, xi;             /* the coefficients g and xi */
} dem_cone_load;

/* 0 and the loads, or -1 (loads NAN) with *why naming the limit broken. */
int dem_ralston_cone(const dem_cone_ice *c, dem_cone_load *out, const char **why);

/* "As much as the scene needs" (issue 25): which load model a station's
 * scene calls for. The DEM runs only where ice is present (concentration
 * >= min_concentration), moving (drift speed >= min_speed) and thick
 * enough to matter (thickness >= min_thickness); elsewhere the cheap
 * formula. force: DEM_CHOOSE_AUTO, or a key forcing either model. */
enum { DEM_CHOOSE_AUTO = 0, DEM_CHOOSE_CHEAP = 1, DEM_CHOOSE_DEM = 2 };
enum { DEM_MODEL_CHEAP = 1, DEM_MODEL_DEM = 2 };

typedef struct dem_scene_keys {
    double min_concentration; /* fraction, [0, 1] */
    double min_speed;         /* m s-1 */
    double min_thickness;     /* m */
    int force;                /* DEM_CHOOSE_* */
} dem_scene_keys;

/* Returns DEM_MODEL_*; *why points at a static sentence saying why (the
 * first threshold not reached, all reached, or the forcing key), or -1
 * with *why naming the bad value (NaN input, a threshold out of range). */
int dem_scene_choose(const dem_scene_keys *k, double concentration, double speed,
                     double thickness, const char **why);

#endif
