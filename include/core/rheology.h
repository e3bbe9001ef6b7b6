/* Constitutive laws, per particle, vertically integrated (N/m).
 *
 * Hibler viscous-plastic (PHYSICS.md section 3, seed eq. 3):
 *   S = 2 eta e + (zeta - eta) tr(e) I - P_r/2 I
 *   zeta = min(P / (2 max(Delta, Delta_min)), zeta_max_factor P),  eta = zeta / e^2
 * (the two caps coincide for the defaults: 1 / (2 * 2e-9 s^-1) = 2.5e8 s). P is the vertically integrated
 * strength P_int = P0 hbar exp(-C (1 - A)) for both pressure forms: the
 * seed's P0 exp(-C(1-A)) multiplied by the hbar of its div(hbar sigma),
 * and Hibler's P* h exp(-C(1-A)) with h the mean thickness hbar; they
 * differ in the constant (P0 = 1e4 vs P* = 2.75e4 N/m^2) and the seed has
 * no replacement pressure. With replacement pressure P_r = 2 zeta Delta
 * (stress vanishes at rest), else P_r = P.
 */
#ifndef SPHICE_CORE_RHEOLOGY_H
#define SPHICE_CORE_RHEOLOGY_H

#include <math.h>
#include "core/params.h"

/* Integrated ice strength, N/m. hbar = A h_i. */
static inline double sph_ice_strength(const sph_params *p, double hbar, double A)
{
    return p->P0 * hbar * exp(-p->C * (1.0 - A));
}

/* Viscous-plastic stress from strain rates; returns zeta. */
static inline double sph_vp_stress(const sph_params *p, double P, double e11, double e22,
                                   double e12, double *s11, double *s22, double *s12)
{
    double eI = e11 + e22;
    double d = e11 - e22;
    double eII2 = d * d + 4.0 * e12 * e12;
    double inv_e2 = 1.0 / (p->ecc * p->ecc);
    double Delta = sqrt(eI * eI + eII2 * inv_e2);
    double Dreg = Delta > p->delta_min ? Delta : p->delta_min;
    double zeta = P / (2.0 * Dreg);
    if (zeta > p->zeta_max_factor * P) /* both caps honoured; equal for the defaults */
        zeta = p->zeta_max_factor * P;
    double eta = zeta * inv_e2;
    double Pr = p->replacement_pressure ? 2.0 * zeta * Delta : P;
    double iso = (zeta - eta) * eI - 0.5 * Pr;
    *s11 = 2.0 * eta * e11 + iso;
    *s22 = 2.0 * eta * e22 + iso;
    *s12 = 2.0 * eta * e12;
    return zeta;
}

/* Shen, Hibler & Lepparanta (1987) floe-collision rheology (PHYSICS.md
 * section 3): gamma = rho_i D^2 h_i / 4 * C0^1.5 / (C0^1.5 - A^1.5),
 * eta = gamma (1 + e_r) / (3 pi) v'/d, zeta = 3 eta,
 * P = gamma sqrt(2) (1 + e_r) / pi^2 (v'/d)^2, all already integrated
 * (gamma carries h_i). Stress S = 2 eta e + (zeta - eta) tr(e) I - P I.
 * A is capped at 0.99 C0 where gamma is singular. Returns zeta. */
static inline double sph_collision_stress(const sph_params *p, double h_i, double A,
                                          double vfluct, double e11, double e22, double e12,
                                          double *s11, double *s22, double *s12)
{
    double C0 = p->coll_max_conc;
    double Ae = A < 0.99 * C0 ? A : 0.99 * C0;
    double c15 = C0 * sqrt(C0), a15 = Ae * sqrt(Ae);
    double D = p->coll_floe_diameter;
    double gamma = p->rho_i * D * D * h_i * 0.25 * c15 / (c15 - a15);
    double rate = vfluct / D;
    double er = p->coll_restitution;
    double eta = gamma * (1.0 + er) / (3.0 * M_PI) * rate;
    double zeta = 3.0 * eta;
    double P = gamma * sqrt(2.0) * (1.0 + er) / (M_PI * M_PI) * rate * rate;
    double eI = e11 + e22;
    double iso = (zeta - eta) * eI - P;
    *s11 = 2.0 * eta * e11 + iso;
    *s22 = 2.0 * eta * e22 + iso;
    *s12 = 2.0 * eta * e12;
    return zeta;
}

#endif
