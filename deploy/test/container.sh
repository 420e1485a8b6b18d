#!/usr/bin/env bash
# Builds the local container image (deploy/Containerfile.local: `scratch` with the release binary
# and the shared libraries it links; no base image to pull) and checks its root file system by
# running the nightly pipeline inside it on the bundled fixture drives.
#
#   bash deploy/test/container.sh [FLEETDYN_BINARY]     (default target/release/fleetdyn)
#
# 1. Build context: rootfs/ with the binary, every library `ldd` lists (and the loader), a
#    passwd and group entry for the non-root user 10001, the bundled schemas.
# 2. `podman build` (else `buildah bud`) of deploy/Containerfile.local → localhost/fleetdyn:local.
# 3. A container of the image, its root file system with pipelines/ and the fixtures copied to
#    /data (owned by the non-root user); then `fleetdyn run pipelines/nightly.toml` inside it as
#    user 10001: with `podman run` where this host can run containers, else with `chroot` into
#    the container's mounted root file system (hosts whose cgroups or rlimits podman cannot
#    manage).
# 4. The dataset made inside the image must equal, byte for byte, the same run of the same binary
#    on the host (the run reports' wall times aside).
# 5. Removes the container and the image.
#
# Exits 0 when the checks hold, 1 when one fails, 77 when it cannot run here (no podman or
# buildah, or not root for the chroot), each with a printed reason. Prints its wall time.
set -euo pipefail
cd "$(dirname "$0")/../.."
repo=$PWD
t_start=$(date +%s)
skip() {
    echo "container test skipped: $*"
    exit 77
}
fail() {
    echo "container test FAILED: $*" >&2
    exit 1
}

if command -v podman >/dev/null; then
    engine=podman
elif command -v buildah >/dev/null; then
    engine=buildah
else
    skip "neither podman nor buildah is installed"
fi
[ "$(id -u)" = 0 ] || skip "not root (the check mounts the image's root file system)"
bin=$(realpath "${1:-target/release/fleetdyn}")
[ -x "$bin" ] || fail "no fleetdyn binary at $bin (cargo build --release)"

work=$(mktemp -d /tmp/fleetdyn-container.XXXXXX)
image=localhost/fleetdyn:local
ctr=""
cleanup() {
    if [ -n "$ctr" ]; then
        $engine umount "$ctr" >/dev/null 2>&1 || true
        $engine rm -f "$ctr" >/dev/null 2>&1 || true
    fi
    $engine rmi -f "$image" >/dev/null 2>&1 || true
    rm -rf "$work"
}
trap cleanup EXIT

# ---- 1. the build context -----------------------------------------------------------------------
ctx=$work/context
root=$ctx/rootfs
mkdir -p "$root/usr/local/bin" "$root/etc" "$root/data" "$root/usr/share/fleetdyn"
cp "$bin" "$root/usr/local/bin/fleetdyn"
for lib in $(ldd "$bin" | grep -oE '/[^ ]+'); do
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib"
done
echo 'fleetdyn:x:10001:10001:fleetdyn:/data:/usr/sbin/nologin' >"$root/etc/passwd"
echo 'fleetdyn:x:10001:' >"$root/etc/group"
cp -r schemas "$root/usr/share/fleetdyn/schemas"
chown 10001:10001 "$root/data"
cp deploy/Containerfile.local "$ctx/Containerfile"
echo "build context: $(du -sh "$root" | cut -f1) ($(find "$root" -type f | wc -l) files)"

# ---- 2. the image ---------------------------------------------------------------------------------
t0=$(date +%s)
if [ "$engine" = podman ]; then
    podman build -q -t "$image" "$ctx" >"$work/build.log" 2>&1 || fail "podman build: $(tail -3 "$work/build.log")"
else
    buildah bud -q -t "$image" "$ctx" >"$work/build.log" 2>&1 || fail "buildah bud: $(tail -3 "$work/build.log")"
fi
echo "image $image built with $engine in $(($(date +%s) - t0)) s"

# ---- 3. the nightly pipeline inside it ----------------------------------------------------------
stage_data() { # root of a file system: pipelines and fixtures under its /data
    mkdir -p "$1/data/fixtures"
    cp -r pipelines "$1/data/pipelines"
    cp -r fixtures/drives fixtures/vehicles "$1/data/fixtures/"
    chown -R 10001:10001 "$1/data"
}
t0=$(date +%s)
if [ "$engine" = podman ]; then
    ctr=$(podman create --workdir / "$image" run data/pipelines/nightly.toml --output data/out --jobs 2)
    mnt=$(podman mount "$ctr")
else
    ctr=$(buildah from "$image")
    mnt=$(buildah mount "$ctr")
fi
stage_data "$mnt"
how=""
if [ "$engine" = podman ] && podman start -a "$ctr" >"$work/inside.log" 2>&1; then
    how="podman run"
else
    [ "$engine" = podman ] && echo "podman cannot run containers here ($(grep -m1 -oE 'Error: .*' "$work/inside.log" || echo unknown)); chroot into the image's root file system"
    chroot --userspec=10001:10001 "$mnt" /usr/local/bin/fleetdyn --version >/dev/null ||
        fail "the binary does not start in the image's root file system"
    # chroot starts in the new root, as the podman run above does (--workdir /)
    env -i PATH=/usr/local/bin "$(command -v chroot)" --userspec=10001:10001 "$mnt" /usr/local/bin/fleetdyn \
        run data/pipelines/nightly.toml --output data/out --jobs 2 >"$work/inside.log" 2>&1 ||
        fail "the nightly run failed inside the image: $(tail -3 "$work/inside.log")"
    how="chroot"
fi
inside=$mnt/data/out
[ -d "$inside" ] || fail "no dataset inside the image"
echo "nightly pipeline inside the image ($how, user 10001): $(grep -oE '[0-9]+ processed, [0-9]+ reused \(up to date\), [0-9]+ failed' "$work/inside.log") in $(($(date +%s) - t0)) s"

# ---- 4. the same run on the host ------------------------------------------------------------------
host=$work/host
stage_data "$host"
# started in its root with the same relative paths, so both runs record the same input paths
(cd "$host" && "$bin" run data/pipelines/nightly.toml --output data/out --jobs 2) >"$work/host.log" 2>&1 ||
    fail "the host run failed: $(tail -3 "$work/host.log")"
digest() { (cd "$1" && find . -type f ! -name run_report.json ! -name summary.md |
    LC_ALL=C sort | xargs sha256sum); }
n=$(digest "$inside" | wc -l)
[ "$n" -gt 40 ] || fail "only $n files in the dataset made inside the image"
if diff <(digest "$inside") <(digest "$host/data/out") >"$work/diff.txt"; then
    echo "the dataset made inside the image equals the host run's ($n files)"
else
    fail "the dataset made inside the image differs from the host run's: $(head -4 "$work/diff.txt")"
fi
echo "container test passed in $(($(date +%s) - t_start)) s"
