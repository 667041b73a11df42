#!/usr/bin/env bash
# The reliability build (docs/reliability.md): configures build-asan/ with Debian's clang,
# AddressSanitizer + UndefinedBehaviorSanitizer on every target (DDOC_SANITIZE) and the libFuzzer
# targets (DDOC_FUZZ), builds it and runs the whole ctest suite in it: a sanitizer report fails the
# test that caused it (UBSan halts on the first report; ASan reports leaks at exit). The fuzz tests
# (label fuzz) run each target over its corpus and DDOC_FUZZ_RUNS (2000) new inputs. The tool
# sweeps that start ddoc-hopper dozens of times (label sanitizer_slow) are left out: see
# docs/reliability.md.
#
#   bash tools/sanitize.sh [extra ctest arguments, e.g. -R app_test]
#
# Needs the packages of tools/setup.sh (clang, libclang-rt-14-dev among them). Not built here: the
# Python module (python3 is not instrumented; importing it would need LD_PRELOAD of libasan) and the
# Google Benchmark tools (not run by ctest).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${DDOC_ASAN_BUILD_DIR:-"$here/build-asan"}
# -gline-tables-only: the reports keep file:line:column of every frame; the build takes 15-40 %
# less CPU and 0.3 GB instead of 1.8 GB than with full -g (docs/reliability.md).
CC=clang CXX=clang++ cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG" \
  -DDDOC_SANITIZE=ON -DDDOC_FUZZ=ON -DDDOC_BUILD_PYTHON=OFF -DDDOC_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j"$(nproc)"
# detect_leaks: LeakSanitizer at exit; halt_on_error: the first report ends the process with a
# failure; print_stacktrace: UBSan reports with a stack. (detect_stack_use_after_return made the
# Eigen-heavy tests ~10x slower and is left at its default, off.)
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
# Leaks inside third-party libraries (libOSMesa), each with its reason: tools/lsan.supp.
export LSAN_OPTIONS="suppressions=$here/tools/lsan.supp:print_suppressions=0"
# Also left out: four CLI tests that solve u^0 again and again (62, 54, 40 and 38 s under the
# sanitizers), and two that compare whole ddoc-hopper runs (identification, robot variants); the
# paths they take are run by other tests here (docs/reliability.md).
slow='^(CliTest\.(TheLawCacheIsOnByDefaultInTheUserCacheDirectory|EveryShippedScenarioRuns|'
slow+='ModelMjcfFlagReplacesTheScenariosModel|IdentifyReSolvesOnTheRobotsMass|'
slow+='UnmodelledDynamicsVariantsEqualTheirFiles)|LawCacheTest\.AnUnusableFileIsSolvedAgainAndReplaced)$'
ctest --test-dir "$build_dir" --output-on-failure -j2 -LE sanitizer_slow -E "$slow" "$@"
