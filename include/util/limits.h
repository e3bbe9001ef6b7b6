/* Named limits shared by the configuration, the downloads, the forcing
 * reader and the products. One place to change them; every array sized by
 * them and every check against them uses these names, never the numbers.
 */
#ifndef SPHICE_UTIL_LIMITS_H
#define SPHICE_UTIL_LIMITS_H

/* Forcing sources in one configuration (key "forcing", an array). */
#define SPHICE_MAX_SOURCES 8
#define SPHICE_MAX_MEMBERS 256 /* ensemble.members */

/* Files (URL templates, key "urls") of one forcing source. */
#define SPHICE_MAX_FILES 64

/* Provenance lines ("path sha256") of one cycle: every file of every
 * source, so nothing is ever cut. */
#define SPHICE_MAX_PROVENANCE (SPHICE_MAX_SOURCES * SPHICE_MAX_FILES)

/* Longest name of a source, station or domain in the configuration (a
 * buffer for one holds SPHICE_MAX_NAME + 1 bytes). */
#define SPHICE_MAX_NAME 63

/* A limit as text, for messages and documentation: SPHICE_STR(SPHICE_MAX_SOURCES). */
#define SPHICE_STR_(x) #x
#define SPHICE_STR(x) SPHICE_STR_(x)

#endif
