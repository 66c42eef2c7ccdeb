#!/usr/bin/env bash
# Installs the Debian 12 packages vbnl needs that are missing (needs root or sudo).
# Sourced by tools/quickstart.sh and tools/test.sh; run alone it just installs.
set -euo pipefail

VBNL_PACKAGES=(meson ninja-build pkg-config gcc g++ libc6-dev cmake python3 binutils
    libembree-dev libtbb-dev libopenexr-dev libimath-dev libpng-dev libassimp-dev libcmocka-dev libopencolorio-dev
    libopenimageio-dev libfreetype-dev)
# Not needed to build: Slurm for `vbnl farm` and its test on a one-machine cluster
# (tools/slurm/local_cluster.sh; about 13 MB installed). `bash tools/deps.sh slurmctld slurmd
# slurm-client munge` installs them; CI does (.ci/run).

vbnl_install_deps() {
    local missing=()
    for p in "${VBNL_PACKAGES[@]}" "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    echo "installing: ${missing[*]}" >&2
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
    vbnl_install_deps "$@"
fi
