# What the farm tests share (sourced by test_farm.sh and test_farm_slurm.sh after
# tests/cli/tap.sh): the comparison of a merged image with the single render's. Needs $SAME,
# the exr_same program.
# The attributes a merged header must share with the single render's: everything that does not
# depend on timing (the rays too: every pixel's paths are the same).
DET=vbnl/version,vbnl/integrator,vbnl/parameters,vbnl/seed,vbnl/sampler,vbnl/spp,vbnl/rays,vbnl/partial
DET=$DET,vbnl/time_budget
# same NAME SINGLE.exr MERGED.exr [SINGLE.png MERGED.png] [-- WHY...]: pixels bit for bit, the
# header's attributes (every one of the single render's, the deterministic ones equal), PNG bytes
same() {
    local name=$1 out
    if out=$("$SAME" "$2" "$3" --attrs "$DET" --has-all 2>&1) && { [ $# -lt 5 ] || cmp "$4" "$5" >/dev/null 2>&1; }; then
        ok "$name"
    else
        not_ok "$name" "$out" "$( [ $# -ge 5 ] && cmp "$4" "$5" 2>&1)"
    fi
}
