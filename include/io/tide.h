/* Harmonic tide prediction: astronomical arguments, nodal corrections and
 * summation for the eight main constituents. No I/O (the harmonic grid
 * files are read by the forcing reader, format in docs/forcing.md).
 *
 * A constituent k contributes f_k A_k cos(V_k(t) + u_k - G_k), with
 *   V_k(t) = V0_k(t_ref) + omega_k (t - t_ref)
 * where V0_k is the equilibrium argument from the mean longitudes at the
 * reference time, omega_k the standard speed, and f_k, u_k the nodal
 * factor and angle evaluated at t_ref (they change by < 0.1 % over a
 * 10-day forecast). G_k is the Greenwich phase lag of the constants.
 */
#ifndef SPHICE_IO_TIDE_H
#define SPHICE_IO_TIDE_H

typedef enum {
    TIDE_M2 = 0, TIDE_S2, TIDE_N2, TIDE_K2, TIDE_K1, TIDE_O1, TIDE_P1, TIDE_Q1,
    TIDE_NCONST
} tide_constituent;

/* Lowercase name "m2".. ; index from a name (case-insensitive), -1 if unknown. */
const char *tide_constituent_name(int k);
int tide_constituent_index(const char *name);

/* Standard speed in degrees per mean solar hour (M2 28.9841042 ...). */
double tide_speed_deg_per_hour(int k);

/* Mean longitudes in degrees at model time t (seconds since 1970 UTC),
 * Schureman (1958) Table 1, T in Julian centuries of 36525 days from
 * 1899-12-31 12:00 UT:
 *   s  = 270.434164 + 481267.8831 T - 0.001133 T^2 + 0.0000019 T^3  (moon)
 *   h  = 279.696678 + 36000.768925 T + 0.0003025 T^2              (sun)
 *   p  = 334.329556 + 4069.0340329 T - 0.010325 T^2 - 0.000012 T^3 (lunar perigee)
 *   N  = 259.183275 - 1934.142008 T + 0.002078 T^2 + 0.0000022 T^3 (lunar node)
 * and the hour angle of the mean sun at Greenwich tau = 180 + 15 * UT hours. */
typedef struct tide_astro {
    double s, h, p, N, tau; /* degrees, reduced to [0, 360) */
} tide_astro;
void tide_astro_at(double t, tide_astro *a);

/* Equilibrium argument V0 of constituent k at time t, degrees in [0,360)
 * (Schureman Table 2):
 *   M2 2tau-2s+2h    S2 2tau        N2 2tau-3s+2h+p   K2 2tau+2h
 *   K1 tau+h-90      O1 tau-2s+h+90 P1 tau-h+90       Q1 tau-3s+h+p+90 */
double tide_v0_deg(int k, double t);

/* Nodal factor f and angle u (degrees) of constituent k at time t
 * (Schureman 1958): with obliquity w = 23.452, lunar inclination
 * i = 5.145 degrees,
 *   cos I = cos w cos i - sin w sin i cos N
 *   tan((N-xi+nu)/2) = cos((w-i)/2)/cos((w+i)/2) tan(N/2)    (eq. 214)
 *   tan((N-xi-nu)/2) = sin((w-i)/2)/sin((w+i)/2) tan(N/2)    (eq. 215)
 *   tan nu'   = sin 2I sin nu / (sin 2I cos nu + 0.3347)       (eq. 224)
 *   tan 2nu'' = sin^2 I sin 2nu / (sin^2 I cos 2nu + 0.0727)  (eq. 232)
 *   M2, N2: f = cos^4(I/2) / 0.9154                 u = 2xi - 2nu
 *   O1, Q1: f = sin I cos^2(I/2) / 0.3800           u = 2xi - nu
 *   K1:     f = sqrt(0.8965 sin^2 2I + 0.6001 sin 2I cos nu + 0.1006), u = -nu'
 *   K2:     f = sqrt(19.0444 sin^4 I + 2.7702 sin^2 I cos 2nu + 0.0981), u = -2nu''
 *   S2, P1: f = 1, u = 0 (solar). */
void tide_nodal(int k, double t, double *f, double *u_deg);

/* Argument terms for summation with a fixed reference time. */
typedef struct tide_args {
    double t_ref;
    double f[TIDE_NCONST];
    double v0u_rad[TIDE_NCONST];   /* V0(t_ref) + u(t_ref), radians */
    double omega_rad_s[TIDE_NCONST];
} tide_args;
/* nodal == 0 disables nodal corrections (f = 1, u = 0). */
void tide_args_init(tide_args *a, double t_ref, int nodal);
/* Phase V0 + u + omega (t - t_ref) in radians, and f, for constituent k. */
double tide_phase_rad(const tide_args *a, int k, double t);

/* One point: sum over the constituents present (amp[k] < 0 or NaN = absent)
 * of f A cos(phase - G); amp in any unit, phase lag G in degrees. */
double tide_predict(const tide_args *a, double t, const double amp[TIDE_NCONST],
                    const double phase_deg[TIDE_NCONST]);

#endif
