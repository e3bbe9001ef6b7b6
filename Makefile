# sphice: operational SPH sea-ice forecast service.
#
# Layers (enforced by `make layers`, part of `make check`):
#   src/core     numerical core: no I/O, no logging, no allocation in a step
#   src/util     small service-independent helpers (errors, time, atomic files)
#   src/io       NetCDF, downloads, rasters, products (uses core + util)
#   src/service  configuration, forecast engine, scheduler, daemon, status
#   src/main.c   the `sphice` program on top
#
# Every *.c under src/{core,util,io,service} goes into build/libsphice.a;
# every tests/test_*.c is its own test program; every bench/bench_*.c its
# own benchmark; every tools/*.c its own tool. Adding a file needs no edit here.

PREFIX  ?= /usr/local
DESTDIR ?=
CC      ?= cc
PKGS    := netcdf hdf5 libcurl libcjson gsl proj udunits libmicrohttpd sqlite3 cairo libsystemd libcrypto gdal
PKG_CFLAGS := $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
PKG_LIBS   := $(shell pkg-config --libs $(PKGS) 2>/dev/null)
OPT     ?= -O2
CFLAGS  ?= $(OPT) -g
WARN    := -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes \
           -Wno-unused-parameter -Wvla -Wformat=2
ALL_CFLAGS = -std=c11 -D_GNU_SOURCE -fopenmp $(WARN) -Iinclude $(PKG_CFLAGS) $(CFLAGS) \
             -DSPHICE_VERSION='"$(VERSION)"' -DSPHICE_GIT='"$(GITREV)"'
LDLIBS  := $(PKG_LIBS) -lgsl -lgslcblas -lm -fopenmp -lpthread
VERSION := 0.1.0
GITREV  := $(shell git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)

# MPI=1: built with OpenMPI's mpicc into build-mpi/ (ensemble members over
# ranks, docs/ensemble.md; `sh tools/install-deps.sh --mpi` installs it)
ifeq ($(MPI),1)
CC      := mpicc
BUILD   ?= build-mpi
ALL_CFLAGS += -DSPHICE_MPI
endif
BUILD   ?= build
# each layer may hold rooms one folder deep (src/core/rheology/, src/io/inputs/ ...)
LIB_SRC := $(wildcard src/util/*.c $(foreach l,core io service,src/$(l)/*.c src/$(l)/*/*.c))
LIB_OBJ := $(LIB_SRC:%.c=$(BUILD)/%.o)
TEST_SRC := $(wildcard tests/test_*.c)
TEST_BIN := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)
BENCH_SRC := $(wildcard bench/bench_*.c)
BENCH_BIN := $(BENCH_SRC:bench/%.c=$(BUILD)/bench/%)
TOOL_SRC := $(wildcard tools/*.c)
TOOL_BIN := $(TOOL_SRC:tools/%.c=$(BUILD)/tools/%)

.SECONDARY:
.PHONY: all deps check check-long sanitize valgrind layers demo demo-season demo-forcing bench clean install tests tools
.PHONY: fuzz fuzz-build fuzz-bins fuzz-smoke-build soak
all: $(BUILD)/sphice tools

deps:
	tools/install-deps.sh

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	@echo "CC $<"
	@$(CC) $(ALL_CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/libsphice.a: $(LIB_OBJ)
	@rm -f $@
	@ar rcs $@ $^

$(BUILD)/sphice: $(BUILD)/src/main.o $(BUILD)/libsphice.a
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -o $@ $^ $(LDLIBS)

$(BUILD)/tests/%: $(BUILD)/tests/%.o $(BUILD)/libsphice.a
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -o $@ $^ $(LDLIBS)

$(BUILD)/bench/%: $(BUILD)/bench/%.o $(BUILD)/libsphice.a
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -o $@ $^ $(LDLIBS)

$(BUILD)/tools/%: $(BUILD)/tools/%.o $(BUILD)/libsphice.a
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -o $@ $^ $(LDLIBS)

tests: $(TEST_BIN) $(BUILD)/sphice
tools: $(TOOL_BIN)

# The layers' objects, for `make layers`.
CORE_OBJ    := $(filter $(BUILD)/src/core/%,$(LIB_OBJ))
UTIL_OBJ    := $(filter $(BUILD)/src/util/%,$(LIB_OBJ))
IO_OBJ      := $(filter $(BUILD)/src/io/%,$(LIB_OBJ))
SERVICE_OBJ := $(filter $(BUILD)/src/service/%,$(LIB_OBJ))
MAIN_OBJ    := $(BUILD)/src/main.o
# Calls the core never makes (nm names, as the compiler emits them): stdio and
# file I/O, NetCDF, HTTP, databases, graphics, journald, logging.
LAYERS_STDIO := v?f?printf|v?dprintf|puts|fputs|fputc|putc|putchar|perror|fgets|fscanf|scanf
LAYERS_FILES := fopen|fdopen|freopen|fclose|fread|fwrite|fflush|open|openat|creat|read|write|close|unlink|rename|mkdir|opendir|syslog
LAYERS_CORE_IO := ^_*($(LAYERS_STDIO)|$(LAYERS_FILES))(64)?(_chk)?$$|^(stdout|stderr|stdin)$$|^(nc|curl|sqlite3|MHD|cairo|cJSON|sd|H5)_|^sph_log_|^log_
# Calls main.o never makes: it reaches forcing and HTTP only through the service.
LAYERS_MAIN_CALLS := ^(forcing|curl)_

# Includes: the core never includes I/O or service headers, io/util never
# service ones. Calls (nm over the built objects): the core calls no symbol
# of util, io, service or main and no I/O or logging; util none of io,
# service or main; io none of service or main; main.o no forcing_* or curl_*.
layers: $(LIB_OBJ) $(MAIN_OBJ)
	@bad=$$(grep -nE '#include *"(io|service|util)/|#include *<(stdio|netcdf|curl/curl|cjson/cJSON|sqlite3|microhttpd|cairo)\.h>' src/core/*.c src/core/*/*.c src/core/*.h src/core/*/*.h include/core/*.h 2>/dev/null || true); \
	if [ -n "$$bad" ]; then echo "layers: core includes I/O or service headers:"; echo "$$bad"; exit 1; fi; \
	bad=$$(grep -nE '#include *"service/' src/io/*.c src/io/*/*.c src/io/*.h src/io/*/*.h src/util/*.c include/io/*.h include/util/*.h 2>/dev/null || true); \
	if [ -n "$$bad" ]; then echo "layers: io/util include service headers:"; echo "$$bad"; exit 1; fi; \
	d=$(BUILD)/layers; mkdir -p $$d; \
	defs() { nm -g --defined-only "$$@" | awk 'NF == 3 { print $$3 }' | sort -u; }; \
	defs $(UTIL_OBJ) $(IO_OBJ) $(SERVICE_OBJ) $(MAIN_OBJ) >$$d/above-core; \
	defs $(IO_OBJ) $(SERVICE_OBJ) $(MAIN_OBJ) >$$d/above-util; \
	defs $(SERVICE_OBJ) $(MAIN_OBJ) >$$d/above-io; \
	: >$$d/none; \
	fail=0; \
	calls() { \
	  nm -u "$$1" | awk '{ print $$NF }' | sort -u >$$d/uses; \
	  bad=$$( { grep -Fx -f "$$2" $$d/uses; grep -E "$$3" $$d/uses; } | sort -u | grep -Fxv -f "$$4" | tr '\n' ' '); \
	  if [ -n "$$bad" ]; then echo "layers: $$1 ($$5) calls $$bad"; fail=1; fi; \
	}; \
	for o in $(CORE_OBJ); do \
	  calls $$o $$d/above-core '$(LAYERS_CORE_IO)' $$d/none "core: no util, io, service, I/O or logging"; done; \
	for o in $(UTIL_OBJ); do calls $$o $$d/above-util '^$$' $$d/none "util: no io or service"; done; \
	for o in $(IO_OBJ); do calls $$o $$d/above-io '^$$' $$d/none "io: no service"; done; \
	calls $(MAIN_OBJ) $$d/none '$(LAYERS_MAIN_CALLS)' $$d/none "main: no forcing_* or curl_*"; \
	if [ $$fail -ne 0 ]; then exit 1; fi; \
	echo "layers: ok"

# The MPI build for test_ensemble_mpi, test_mpi_dd and test_mpi_season, when OpenMPI's mpicc is installed.
.PHONY: mpi-build
mpi-build:
	@if command -v mpicc >/dev/null 2>&1 && [ "$(MPI)" != 1 ]; then \
	  $(MAKE) --no-print-directory MPI=1 BUILD=build-mpi build-mpi/sphice build-mpi/tests/test_mpi_dd build-mpi/tests/test_mpi_season; \
	else echo "mpi-build: mpicc not installed: test_ensemble_mpi will skip (sh tools/install-deps.sh --mpi)"; fi

# The test suite: every test program, then the summary line.
check: all tests layers fuzz-smoke-build mpi-build
	@BUILD=$(BUILD) sh tests/run.sh $(TEST_BIN) tests/fuzz/fuzz_smoke

# Long validations (year-long columns, steady states at full resolution).
check-long: all tests
	@SPHICE_LONG=1 BUILD=$(BUILD) sh tests/run.sh $(TEST_BIN)

# AddressSanitizer + UndefinedBehaviorSanitizer build of the whole suite.
sanitize:
	$(MAKE) BUILD=build-asan OPT=-O1 \
	  CFLAGS="-O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all" \
	  LDLIBS="$(LDLIBS) -fsanitize=address,undefined" check

# valgrind memcheck over the test programs (reduced sizes via SPHICE_QUICK).
valgrind: all tests
	@SPHICE_QUICK=1 SPHICE_VALGRIND=1 BUILD=$(BUILD) sh tests/run.sh $(TEST_BIN)

demo: all
	sh tools/demo.sh

# Regenerates the synthetic Liaodong Bay 1999 scene (committed files).
demo-forcing: $(BUILD)/tools/gen_liaodong
	$(BUILD)/tools/gen_liaodong forcing/liaodong-1999

# The freeze-up scene (docs/season.md): 30 days from open water, forcing generated into build/.
demo-season: all $(BUILD)/tools/gen_season $(BUILD)/tools/season_summary
	BUILD=$(BUILD) sh tools/demo_season.sh

bench: all $(BENCH_BIN)
	sh bench/run.sh

# Everything goes under $(DESTDIR)$(PREFIX) unless a directory is given:
# SYSCONFDIR (default PREFIX/etc; PREFIX=/usr gives /etc), UNITDIR,
# SYSUSERSDIR, DOCDIR. The configuration is installed as *.example and
# copied to sphice.json only where none exists: an operator's file is never
# overwritten. The units' Documentation= points at DOCDIR/README.md.
SYSCONFDIR  ?= $(if $(filter /usr,$(PREFIX)),/etc,$(PREFIX)/etc)
UNITDIR     ?= $(PREFIX)/lib/systemd/system
SYSUSERSDIR ?= $(PREFIX)/lib/sysusers.d
DOCDIR      ?= $(PREFIX)/share/doc/sphice
install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(SYSCONFDIR)/sphice $(DESTDIR)$(UNITDIR) \
	           $(DESTDIR)$(SYSUSERSDIR) $(DESTDIR)$(DOCDIR)/docs
	install -m 755 $(BUILD)/sphice $(DESTDIR)$(PREFIX)/bin/sphice
	for c in etc/*.json; do install -m 644 "$$c" $(DESTDIR)$(SYSCONFDIR)/sphice/$$(basename $$c).example; done
	[ -e $(DESTDIR)$(SYSCONFDIR)/sphice/sphice.json ] || \
	  install -m 644 etc/sphice.json $(DESTDIR)$(SYSCONFDIR)/sphice/sphice.json
	for u in systemd/*.service systemd/*.timer; do \
	  sed -e 's#@PREFIX@#$(PREFIX)#g' -e 's#@SYSCONFDIR@#$(SYSCONFDIR)#g' -e 's#@DOCDIR@#$(DOCDIR)#g' \
	    "$$u" > $(DESTDIR)$(UNITDIR)/$$(basename $$u) || exit 1; done
	install -m 644 systemd/sphice.sysusers $(DESTDIR)$(SYSUSERSDIR)/sphice.conf
	install -m 644 README.md $(DESTDIR)$(DOCDIR)/README.md
	install -m 644 docs/*.md $(DESTDIR)$(DOCDIR)/docs/
	@echo "installed under $(DESTDIR)$(PREFIX) (configuration: $(DESTDIR)$(SYSCONFDIR)/sphice);" \
	  "create the service user with: systemd-sysusers"

# libFuzzer harnesses (tests/fuzz/fuzz_*.c) under ASan and UBSan, built with
# clang into build-fuzz/ (library included); `make fuzz` runs each for
# FUZZ_SECONDS on its seed corpus, `make check` a short smoke of each
# (tests/fuzz/fuzz_smoke) when clang is installed (sh tools/install-deps.sh --fuzz).
FUZZ_BUILD   := build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_CFLAGS  := -O1 -g -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer \
                -fno-sanitize-recover=all
FUZZ_SRC     := $(wildcard tests/fuzz/fuzz_*.c)
FUZZ_BIN     := $(FUZZ_SRC:tests/fuzz/%.c=$(BUILD)/fuzz/%)

$(BUILD)/fuzz/fuzz_%: $(BUILD)/tests/fuzz/fuzz_%.o $(BUILD)/libsphice.a
	@mkdir -p $(dir $@)
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -fsanitize=fuzzer -Wl,--wrap=ut_read_xml,--wrap=ut_free_system -o $@ $^ $(LDLIBS)

$(BUILD)/fuzz/gen_corpus: $(BUILD)/tests/fuzz/gen_corpus.o $(BUILD)/libsphice.a
	@mkdir -p $(dir $@)
	@echo "LD $@"
	@$(CC) $(ALL_CFLAGS) -o $@ $^ $(LDLIBS)

# (inside the clang build) the harnesses and the seed corpora
fuzz-bins: $(FUZZ_BIN) $(BUILD)/fuzz/gen_corpus
	@rm -rf $(BUILD)/fuzz/seeds && mkdir -p $(BUILD)/fuzz/seeds && cp -r tests/fuzz/corpus/* $(BUILD)/fuzz/seeds/
	@ASAN_OPTIONS=detect_leaks=0 $(BUILD)/fuzz/gen_corpus $(BUILD)/fuzz/seeds

fuzz-build:
	@$(MAKE) --no-print-directory BUILD=$(FUZZ_BUILD) CC=clang OPT=-O1 CFLAGS="$(FUZZ_CFLAGS)" fuzz-bins

fuzz-smoke-build:
	@if command -v clang >/dev/null 2>&1; then $(MAKE) --no-print-directory fuzz-build; \
	else echo "note: clang not found: fuzz smoke skipped (sh tools/install-deps.sh --fuzz)"; fi

fuzz: fuzz-build
	@FUZZ_BUILD=$(FUZZ_BUILD) FUZZ_SECONDS=$(FUZZ_SECONDS) sh tests/fuzz/run.sh

# 200 accelerated cycles of a small real forecast under `sphice serve`:
# RSS and open descriptors of the daemon flat, retention kept.
SOAK_CYCLES ?= 200
soak: all
	@SOAK_CYCLES=$(SOAK_CYCLES) BUILD=$(BUILD) sh tools/soak.sh

clean:
	rm -rf build build-asan build-fuzz

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
