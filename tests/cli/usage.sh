#!/usr/bin/env bash
# CLI test of command-line usage: bad usage (no subcommand, unknown subcommand or option, missing
# argument or option value, a value of the wrong type) exits 2 with "meshcvt: error:" on stderr
# and nothing on stdout; --help and --version exit 0; --help lists the subcommands.
# usage: usage.sh /path/to/meshcvt /path/to/tests/data
set -uo pipefail
cli=$1
data=$2
source "$(dirname "$0")/prologue.bash"  # $tmp, fail

# expect_usage_error ARGS...: exit 2, an error line on stderr, nothing on stdout, no output file.
expect_usage_error() {
  "$cli" "$@" >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  [ $rc -eq 2 ] || fail "meshcvt $*: expected exit 2, got $rc (stderr: $(cat "$tmp/err"))"
  grep -q "^meshcvt: error: " "$tmp/err" || fail "meshcvt $*: no 'meshcvt: error:' line: $(cat "$tmp/err")"
  [ ! -s "$tmp/out" ] || fail "meshcvt $*: wrote to stdout: $(cat "$tmp/out")"
  [ ! -e "$tmp/o.off" ] || fail "meshcvt $*: wrote an output file"
}

expect_usage_error                                           # no subcommand
expect_usage_error frobnicate                                # unknown subcommand
expect_usage_error --bogus                                   # unknown global option
expect_usage_error info                                      # missing MESH
expect_usage_error info "$data/elephant.off" --bogus         # unknown option
expect_usage_error info "$data/elephant.off" extra.off       # extra argument
expect_usage_error subdivide "$data/elephant.off" -o "$tmp/o.off"          # missing -k
expect_usage_error subdivide "$data/elephant.off" -k 1                     # missing -o
expect_usage_error subdivide "$data/elephant.off" -o "$tmp/o.off" -k       # -k without a value
expect_usage_error subdivide "$data/elephant.off" -o "$tmp/o.off" -k two   # -k not a number
expect_usage_error subdivide "$data/elephant.off" -o "$tmp/o.off" -k -1    # -k negative

"$cli" --help >"$tmp/out" 2>"$tmp/err" || fail "--help: exit $?"
for sub in info subdivide; do
  grep -Eq "^  $sub " "$tmp/out" || fail "--help does not list '$sub': $(cat "$tmp/out")"
done
# info (order 10) is listed before subdivide (order 80).
info_line=$(grep -En '^  info ' "$tmp/out" | cut -d: -f1)
subdivide_line=$(grep -En '^  subdivide ' "$tmp/out" | cut -d: -f1)
[ "$info_line" -lt "$subdivide_line" ] || fail "--help lists subdivide before info"
"$cli" info --help >"$tmp/out" 2>&1 || fail "info --help: exit $?"
grep -q -- "--json" "$tmp/out" || fail "info --help does not mention --json"
grep -q -- "--no-weld" "$tmp/out" || fail "info --help does not mention --no-weld"
"$cli" subdivide --help >"$tmp/out" 2>&1 || fail "subdivide --help: exit $?"
grep -q -- "--levels" "$tmp/out" || fail "subdivide --help does not mention --levels"
"$cli" --version >"$tmp/out" 2>&1 || fail "--version: exit $?"
grep -q "^meshcvt [0-9]" "$tmp/out" || fail "--version: $(cat "$tmp/out")"

# An output name with an unknown extension is refused before any work: the message names the
# output, not the input (which does not exist here), and the exit is 1 (a file error).
for args in "cluster $tmp/missing.off -n 10 -o $tmp/o.xyz" "coarsen $tmp/missing.off -n 10 -o $tmp/o.xyz" \
            "coarsen $tmp/missing.off -n 10 -o $tmp/o.off --partition $tmp/p.xyz" "subdivide $tmp/missing.off -k 1 -o $tmp/o.xyz"; do
  # shellcheck disable=SC2086
  "$cli" $args >"$tmp/out" 2>"$tmp/err"
  rc=$?
  [ $rc -eq 1 ] || fail "meshcvt $args: expected exit 1, got $rc"
  grep -q "\.xyz: unknown mesh format '.xyz'" "$tmp/err" || fail "meshcvt $args: $(cat "$tmp/err")"
  grep -q "missing.off" "$tmp/err" && fail "meshcvt $args: read the input first: $(cat "$tmp/err")"
done
echo "usage.sh: ok"
