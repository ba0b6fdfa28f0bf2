# Sourced by the CLI tests (tests/cli/*.sh) after their `set` line: $tmp, a temporary directory
# removed on exit, and `fail MESSAGE` (prints "FAIL: MESSAGE" to stderr and exits 1).
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
