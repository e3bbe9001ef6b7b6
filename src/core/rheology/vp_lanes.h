/* Hibler's VP law (sph_vp_stress, include/core/rheology.h) for two
 * particles in two lanes (lanes.h), shared by the VP stress pass
 * (rheology/vp.c) and mEVP's fused stress and relaxation (solver/mevp.c).
 * Private to the core. */
#ifndef SPHICE_CORE_RHEOLOGY_VP_LANES_H
#define SPHICE_CORE_RHEOLOGY_VP_LANES_H

#include "../lanes.h"
#include "core/params.h"

/* sph_vp_stress (include/core/rheology.h) for two particles in two lanes,
 * each lane the scalar law's operations in its order (lanes.h); inv_e2 is
 * its 1 / e^2. Returns zeta. */
static inline sph_v2d sph_vp_stress_two(const sph_params *p, double inv_e2, sph_v2d P, sph_v2d e11,
                                    sph_v2d e22, sph_v2d e12, sph_v2d *s11, sph_v2d *s22,
                                    sph_v2d *s12)
{
    const sph_v2d ie2 = splat2(inv_e2), dmin = splat2(p->delta_min), two = splat2(2.0);
    sph_v2d eI = e11 + e22;
    sph_v2d d = e11 - e22;
    sph_v2d eII2 = d * d + splat2(4.0) * e12 * e12;
    sph_v2d Delta = sqrt2(eI * eI + eII2 * ie2);
    sph_v2d Dreg = sel2((sph_v2l)(Delta > dmin), Delta, dmin);
    sph_v2d zeta = P / (two * Dreg);
    sph_v2d cap = splat2(p->zeta_max_factor) * P;
    zeta = sel2((sph_v2l)(zeta > cap), cap, zeta);
    sph_v2d eta = zeta * ie2;
    sph_v2d Pr = p->replacement_pressure ? two * zeta * Delta : P;
    sph_v2d iso = (zeta - eta) * eI - splat2(0.5) * Pr;
    *s11 = two * eta * e11 + iso;
    *s22 = two * eta * e22 + iso;
    *s12 = two * eta * e12;
    return zeta;
}

#if defined(SPH_HAVE_LANES4)
/* The same law for four particles in four lanes (lanes.h). */
SPH_LANES4_INLINE sph_v4d sph_vp_stress_four(const sph_params *p, double inv_e2, sph_v4d P, sph_v4d e11,
                                           sph_v4d e22, sph_v4d e12, sph_v4d *s11, sph_v4d *s22,
                                           sph_v4d *s12)
{
    const sph_v4d ie2 = splat4(inv_e2), dmin = splat4(p->delta_min), two = splat4(2.0);
    sph_v4d eI = e11 + e22;
    sph_v4d d = e11 - e22;
    sph_v4d eII2 = d * d + splat4(4.0) * e12 * e12;
    sph_v4d Delta = sqrt4(eI * eI + eII2 * ie2);
    sph_v4d Dreg = sel4((sph_v4l)(Delta > dmin), Delta, dmin);
    sph_v4d zeta = P / (two * Dreg);
    sph_v4d cap = splat4(p->zeta_max_factor) * P;
    zeta = sel4((sph_v4l)(zeta > cap), cap, zeta);
    sph_v4d eta = zeta * ie2;
    sph_v4d Pr = p->replacement_pressure ? two * zeta * Delta : P;
    sph_v4d iso = (zeta - eta) * eI - splat4(0.5) * Pr;
    *s11 = two * eta * e11 + iso;
    *s22 = two * eta * e22 + iso;
    *s12 = two * eta * e12;
    return zeta;
}
#endif

#endif
