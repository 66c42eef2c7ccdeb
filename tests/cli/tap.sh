# TAP helpers of the shell tests (sourced): ok NAME, not_ok NAME [LINE ...], expect NAME STATUS
# PATTERN -- COMMAND... (the exit status and an extended regular expression in stdout+stderr), and
# tap_end, which prints the plan and returns non-zero when a check failed.
n=0
failed=0
ok() { n=$((n + 1)); echo "ok $n - $1"; }
not_ok() { n=$((n + 1)); failed=$((failed + 1)); echo "not ok $n - $1"; shift; for l in "$@"; do echo "# $l"; done; }
expect() {
    local name=$1 status=$2 pattern=$3
    shift 4
    local out rc
    out=$("$@" 2>&1)
    rc=$?
    if [ "$rc" -eq "$status" ] && grep -qE -- "$pattern" <<<"$out"; then
        ok "$name"
    else
        not_ok "$name" "exit $rc (want $status), output:" "$out"
    fi
}
tap_end() {
    echo "1..$n"
    [ $failed -eq 0 ]
}
