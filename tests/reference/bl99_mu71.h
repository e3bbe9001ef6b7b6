/* Reference numbers from a peer program (issue 20, "compare like with
 * like"): Bitz's BL99 column (Bitz & Lipscomb 1999) run on
 * test_snow_mu71's own forcing and set-up. Only its numbers are here; its
 * code and its own forcing file are not in this repository.
 *
 * Peer program: C.M. Bitz's 2007 MATLAB column ("Driver for Bitz and
 * Lipscomb column model", June 24, 2007) as ported to Python in the public
 * GitHub repository andrewpauling/pyBL99 (files column/model.py,
 * physics/thermo.py, physics/growb.py, utils/tstmnew.py, utils/state.py,
 * fortran/getabc.f90, constants.py; the search tool stores several
 * versions of them, e.g. utils/tstmnew.py at commit
 * 0d13efb12239df166873a33097846bf61b0e51fb and ce5d23338016648190d54b3a49629dfa73266b66,
 * column/model.py at 30f45ea4ff47dd249dfa37ad05af9ca6d0b4fdbe). It was
 * transcribed into one scratch file outside the repository (NumPy only,
 * the Fortran helpers getabc/tridag/iter_ts_mu as Python; the equations of
 * utils/tstmnew.py were compared line by line with the stored version at
 * 0d13efb) and run unmodified in its physics with Python 3.11.7 and
 * NumPy 1.24.2 (2026-12-02).
 *
 * Forcing: exactly this test's, one row per 1 h step written by
 *   SPHICE_MU71_EXPORT=/tmp/mu71p/hourly.txt build/tests/test_snow_mu71
 * (tests/mu71_forcing.h: MU71 Table 1 linear between mid-month values at
 * the step's mid-time; shortwave down, longwave down, upward sensible and
 * latent in the peer's mW/m^2, MU71's monthly albedo, the test's snowfall
 * per step, 0.40 m a year); the peer's driver loop replaced by one that
 * takes row i for step i (dtau = 3600 s; the peer's own driver steps 12 h
 * and interpolates a daily file).
 *
 * Set-up, the test's: 10 layers; 30 years at 1 h from 3 m of ice, no snow,
 * a linear profile from -25 C at the top to T_f (as sph_column_init);
 * i0 = 0.17 of the absorbed shortwave into bare ice (the peer's io_surf;
 * none under snow, the peer's own rule), extinction 1.5 /m (the peer's
 * kappa); albedo = MU71's monthly value of the forcing (the peer's
 * computed albedo off); emission 0.99 sigma T^4 with all longwave
 * absorbed; c0 2106 J/kg/K for ice and snow, beta 0.13, K0 2.03 W/m/K,
 * T_f = -1.728 C (32 psu, mu 0.054); the peer's own k_s 0.31, rho_s 330,
 * rho_i 917, L0 3.34e5, F_w 2 W/m^2, snow solved as a layer above 1 cm,
 * as the test. Differences that remain (the peer's own): its salinity
 * profile coefficients (0.40706205, 0.57265966 against 0.407, 0.573), 273.16
 * against 273.15 K, a convergence tolerance of 1e-4 K, snowfall added at
 * the end of a step, the shortwave leaving the base discarded (sphice
 * melts the base with it), and the conduction at the snow surface from a
 * quadratic through the surface, the snow centre and the first ice centre
 * (sphice: the two-point conductance 2 k_s / h_s). The last is measured
 * below (_2PT_: the peer with that one expression in the two-point form,
 * alph 2, bet 0 in its tstmnew), as docs/thermo.md's "Fourth look" did on
 * the peer's own forcing.
 *
 * Command (scratch driver, env = the set-up above):
 *   EMIS=0.99 CPICE=2106 BETA=0.13 TFREZ=-1.728 ALB=mu ALBOFF=0 K0=2.03
 *   CPSNO=2106 IO=0.17 python3 hourly.py hourly.txt 30   (IO=0 for i0 = 0;
 *   SNOWFO=1 for _2PT_)
 * Statistics of the 30th year over every step, as test_snow_mu71's: mean,
 * maximum, minimum of the ice thickness (m). The peer's last-year change:
 * +2.6 mm (i0 0.17), -0.6 mm (i0 0); snow maximum 0.398 / 0.400 m; no
 * solver restart and no non-convergence in 262800 steps. */
#ifndef SPHICE_TESTS_REFERENCE_BL99_MU71_H
#define SPHICE_TESTS_REFERENCE_BL99_MU71_H

/* the peer as it is (quadratic snow-surface flux) */
#define BL99_MU71_MEAN 3.5297
#define BL99_MU71_MAX 3.7607
#define BL99_MU71_MIN 3.3989
#define BL99_MU71_I0_0_MEAN 3.0904
#define BL99_MU71_I0_0_MAX 3.3640
#define BL99_MU71_I0_0_MIN 2.9155

/* the same with the snow-surface flux in the two-point form (printed, not asserted) */
#define BL99_MU71_2PT_MEAN 3.3958
#define BL99_MU71_2PT_MAX 3.6289
#define BL99_MU71_2PT_MIN 3.2601
#define BL99_MU71_2PT_I0_0_MEAN 2.9675
#define BL99_MU71_2PT_I0_0_MAX 3.2427
#define BL99_MU71_2PT_I0_0_MIN 2.7874

#endif
