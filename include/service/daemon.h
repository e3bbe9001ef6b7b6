/* The long-running service (`sphice serve`) and the replay (`sphice hindcast`).
 *
 * One main loop ticks every 100 ms (like Redis' serverCron): it reacts to
 * signals (flags set by the handlers, nothing else), pings the systemd
 * watchdog, starts the due cycle in a worker thread, collects the finished
 * one and applies a reloaded configuration between cycles. The status HTTP
 * server runs in libmicrohttpd's own thread and reads shared state under a
 * mutex. */
#ifndef SPHICE_SERVICE_DAEMON_H
#define SPHICE_SERVICE_DAEMON_H

#include <signal.h>
#include "util/err.h"

struct sph_config;

/* Set by the signal handlers (service_install_signals). */
extern volatile sig_atomic_t service_term; /* SIGTERM / SIGINT */
extern volatile sig_atomic_t service_hup;  /* SIGHUP */
/* Installs handlers that only set the flags above (no SA_RESTART), and ignores SIGPIPE. */
void service_install_signals(void);

/* Runs the daemon until SIGTERM. listen (may be NULL) overrides
 * status.listen. Returns the process exit code (0 after SIGTERM). */
int service_serve(const char *config_path, const char *listen);

/* Replays every scheduled cycle in [from, to] with the same cycle code,
 * into out_dir (NULL: paths.hindcast_dir, or output.dir/hindcast), with
 * its own history (state_dir/hindcast.sqlite). Returns the number of
 * failed cycles, or -1 on a setup error (err says why). */
int service_hindcast(const struct sph_config *cfg, double from, double to, const char *out_dir, int force,
                     sph_error *err);

#endif
