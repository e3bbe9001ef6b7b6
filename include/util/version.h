/* The build's version and git revision: the Makefile passes both as -D;
 * a build without them (another build system, an IDE) says "unknown". */
#ifndef SPHICE_UTIL_VERSION_H
#define SPHICE_UTIL_VERSION_H

#ifndef SPHICE_VERSION
#define SPHICE_VERSION "unknown"
#endif
#ifndef SPHICE_GIT
#define SPHICE_GIT "unknown"
#endif

#endif
