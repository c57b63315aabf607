#!/usr/bin/env bash
# Runs one command inside the cached Debian 13 build root.
#
# Must be started by `unshare --mount --propagation private` (the rsrio script does): every mount
# made here lives only in that private namespace and disappears with it, so nothing of the root
# stays mounted on the host after the command, even if it is killed.
#
# usage: enter-root.sh ROOT REPO SHARED_OR_EMPTY WORKDIR CMD [ARGS...]
set -euo pipefail
root=$1 repo=$2 shared=$3 workdir=$4
shift 4

# Refuse to run in the host's mount namespace: the mounts below would outlive us there.
if [ "$(readlink /proc/self/ns/mnt)" = "$(readlink /proc/1/ns/mnt)" ]; then
  echo "enter-root.sh: not in a private mount namespace; refusing to mount (run it through ./rsrio)" >&2
  exit 70
fi

mount --rbind /dev "$root/dev"
mount -t proc proc "$root/proc"
mount -t sysfs sysfs "$root/sys"
mount -t tmpfs -o mode=1777 tmpfs "$root/tmp"
# The repository (and ../shared beside it) at the same path as on the host, so paths printed
# inside and outside the root agree and CMake caches stay valid for both.
mkdir -p "$root$repo"
mount --bind "$repo" "$root$repo"
if [ -n "$shared" ]; then
  mkdir -p "$root$shared"
  mount --bind "$shared" "$root$shared"
fi

# A clean environment: only what the build and the tests need from the caller.
env_args=(HOME=/root LANG=C.UTF-8 "PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
          "TERM=${TERM:-dumb}" RSRIO_IN_BUILD_ROOT=1
          # The compiler cache belongs to the root (same compiler, same headers); paths below the
          # repository are hashed relative to it, so another clone of the project hits the cache.
          # Depend mode: the compiler's own -MD list instead of a second preprocessor pass on a miss.
          CCACHE_DIR=/var/cache/ccache "CCACHE_BASEDIR=$repo" CCACHE_NOHASHDIR=1 CCACHE_DEPEND=1 CCACHE_MAXSIZE=6G)
for v in CI RSRIO_JOBS RSRIO_LOG_LEVEL; do
  if [ -n "${!v:-}" ]; then env_args+=("$v=${!v}"); fi
done
exec chroot "$root" /usr/bin/env -i "${env_args[@]}" /bin/bash -c 'cd "$1" && shift && exec "$@"' enter "$workdir" "$@"
