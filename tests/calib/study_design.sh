#!/usr/bin/env bash
# `calibgen study design` end to end on the small test plate (4 cases):
#  1. sweep files with an unknown axis, an empty range, an empty list or a
#     value of the wrong type are refused in one line naming the file and key;
#  2. the same sweep under `mpirun -np 2` gives design.csv bit for bit equal to
#     the one-process run, with cases run on both ranks;
#  3. a 2-rank run with one rank SIGKILLed mid-sweep, then rerun, skips the
#     stored cases, reruns the lost ones and gives the same design.csv again.
# usage: study_design.sh CALIBGEN SOURCE_DIR MPIEXEC WORK_DIR
set -uo pipefail
calibgen=$1 src=$2 mpiexec=$3 work=$4
sweep=$src/scenes/studies/test-study-small-sweep.toml
# Open MPI refuses root unless told (test machines and containers run as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# No network interfaces needed between ranks on one machine.
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() { echo "FAIL: $*" >&2; exit 1; }
cases() { ls "$1/cases" 2>/dev/null | grep -c '\.case$'; }

# 1. Refusals: exit status 1, one line on stderr naming the file and the key, nothing written.
cp "$src/scenes/test-study-small.toml" .
refuse() { # name, axes line, expected key
  printf 'base = "test-study-small.toml"\n[axes]\n%s\n' "$2" > "$1.toml"
  "$calibgen" study design "$1.toml" --report "out-$1" > /dev/null 2> "$1.err"
  local rc=$?
  [ $rc -eq 1 ] || fail "$1: exit status $rc, expected 1"
  [ "$(wc -l < "$1.err")" -eq 1 ] || fail "$1: expected one line, got: $(cat "$1.err")"
  grep -q "$1.toml: $3: " "$1.err" || fail "$1: the message does not name $1.toml and $3: $(cat "$1.err")"
  [ ! -e "out-$1" ] || fail "$1: wrote out-$1"
}
refuse unknown-axis 'colour = ["red"]' 'axes.colour'
refuse empty-range 'thickness_m = {from = 0.004, to = 0.002, step = 0.001}' 'axes.thickness_m.to'
refuse empty-list 'exciter_count = []' 'axes.exciter_count'
refuse wrong-type 'exciter_count = [4, "six"]' 'axes.exciter_count'
grep -q 'unknown axis' unknown-axis.err || fail "unknown axis: $(cat unknown-axis.err)"
grep -q 'empty range' empty-range.err || fail "empty range: $(cat empty-range.err)"

# 2. One process, then two ranks.
"$calibgen" study design "$sweep" --report one -q || fail "the one-process run failed"
[ "$(cases one)" -eq 4 ] || fail "one: $(cases one) case files, expected 4"
[ "$(grep -c ',ok,' one/design.csv)" -eq 4 ] || fail "one: not every case ran: $(cat one/design.csv)"
"$mpiexec" -np 2 --oversubscribe "$calibgen" study design "$sweep" --report two -q || fail "the 2-rank run failed"
cmp one/design.csv two/design.csv || fail "2 ranks: design.csv differs from one process"
ranks=$(tail -n +2 two/timing.csv | cut -d, -f3 | sort -u | tr '\n' ' ')
[ "$ranks" = "0 1 " ] || fail "2 ranks: cases ran on ranks '$ranks', expected both 0 and 1"

# 3. SIGKILL one rank once the first case is stored, then resume.
"$mpiexec" -np 2 --oversubscribe "$calibgen" study design "$sweep" --report kill -q > /dev/null 2>&1 &
job=$!
for _ in $(seq 1200); do [ "$(cases kill)" -ge 1 ] && break; sleep 0.05; done
[ "$(cases kill)" -ge 1 ] || { kill -9 $job; fail "no case stored within 60 s"; }
rank_pid=$(pgrep -P $job | tail -1)
[ -n "$rank_pid" ] || fail "no rank process under mpirun"
kill -9 "$rank_pid"
wait $job && fail "the job survived a SIGKILLed rank"
stored=$(cases kill)
[ "$stored" -lt 4 ] || fail "the sweep finished before the kill: no resume to test"
[ ! -e kill/design.csv ] || fail "the killed run wrote design.csv"
"$mpiexec" -np 2 --oversubscribe "$calibgen" study design "$sweep" --report kill 2> resume.err > /dev/null ||
  fail "the resumed run failed: $(cat resume.err)"
grep -q "4 cases, $stored already done, $((4 - stored)) to run" resume.err ||
  fail "the rerun did not resume from $stored stored cases: $(head -1 resume.err)"
cmp one/design.csv kill/design.csv || fail "killed and resumed: design.csv differs from one process"
ls kill/cases | grep -q '\.tmp\.' && fail "temporary files left in kill/cases"
echo "study_design: refusals, 1 vs 2 ranks, kill and resume ($stored of 4 cases stored before the kill): ok"
