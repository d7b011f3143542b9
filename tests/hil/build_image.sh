#!/usr/bin/env bash
# Builds the hardware-in-the-loop guest: a Debian kernel (vmlinuz) and an initramfs
# (initramfs.cpio.gz) holding busybox, the CAN, evdev and uinput kernel modules, can-utils, numen's HIL programs
# from BUILD_DIR and the scenario scripts. See docs/hil.md.
#
# Usage: tests/hil/build_image.sh BUILD_DIR OUT_DIR
#   BUILD_DIR: a numen build configured with -DNUMEN_BUILD_HIL=ON in which numen_hil_tests and
#              numen_hil_can are built (tests/hil/run.sh does both).
#   OUT_DIR:   receives vmlinuz, initramfs.cpio.gz and the staging tree rootfs/.
# Guest packages come from tests/hil/deps (cache: $NUMEN_HIL_CACHE or <repo>/build-hil/deps).
# Exits non-zero with a message naming what is missing.
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 BUILD_DIR OUT_DIR" >&2
  exit 2
fi
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
build="$(cd "$1" && pwd)"
mkdir -p "$2"
out="$(cd "$2" && pwd)"
cache="${NUMEN_HIL_CACHE:-$repo/build-hil/deps}"
die() { echo "build_image: $*" >&2; exit 1; }

bash "$here/deps" "$cache" >/dev/null
cache="$(cd "$cache" && pwd)"
kernel_pkg="$(cat "$cache/kernel-package")"
kroot="$cache/root/$kernel_pkg"
vmlinuz="$(ls "$kroot"/boot/vmlinuz-* | head -n 1)"
kver="${vmlinuz##*/vmlinuz-}"
moddir="$kroot/lib/modules/$kver"
[ -d "$moddir" ] || die "no modules for $kver in $moddir"

[ -x "$build/numen" ] || die "$build/numen missing (build the numen target)"
for prog in numen_hil_tests numen_hil_can; do
  [ -x "$build/tests/$prog" ] || die "$build/tests/$prog missing (configure with -DNUMEN_BUILD_HIL=ON and build it)"
done

root="$out/rootfs"
rm -rf "$root"
mkdir -p "$root"/{bin,dev,proc,sys,tmp,etc,hil/bin,hil/scenarios,lib/modules}
ln -s bin "$root/sbin"
mkdir -p "$root/usr"
ln -s ../bin "$root/usr/bin"
ln -s ../bin "$root/usr/sbin"

# Copies the shared libraries an executable needs (ldd), and the dynamic loader, to the same
# paths in the image.
copy_libs() {
  local exe="$1" lib
  # ldd prints "name => /path (addr)" and "/lib64/ld-linux-x86-64.so.2 (addr)".
  for lib in $(ldd "$exe" 2>/dev/null | awk '/=> \// {print $3} /^\t\// {print $1}'); do
    if [ ! -e "$root$lib" ]; then
      mkdir -p "$root$(dirname "$lib")"
      cp -L "$lib" "$root$lib"
    fi
  done
}

# 1. busybox and its applets.
cp "$cache/root/busybox-static/bin/busybox" "$root/bin/busybox"
for applet in $("$root/bin/busybox" --list); do
  [ -e "$root/bin/$applet" ] || ln -s busybox "$root/bin/$applet"
done

# 2. Kernel modules: can, can-raw, can-dev, vcan, evdev (the /dev/input/eventN handler) and
# uinput (user-space input devices; both CONFIG_*=m in Debian's kernel) and what they depend on (the `depends=` field
# of each module's .modinfo section; the package ships no modules.dep, depmod runs at install).
# Compressed modules are decompressed (busybox insmod reads plain .ko only).
declare -A mod_path=()
while IFS= read -r -d '' f; do
  base="${f##*/}"
  base="${base%%.ko*}"
  mod_path["${base//-/_}"]="$f"
done < <(find "$moddir/kernel" -name '*.ko*' -print0)
plain_module() {  # plain_module FILE DEST: decompress or copy
  case "$1" in
    *.ko) cp "$1" "$2" ;;
    *.ko.xz) xz -dc "$1" >"$2" ;;
    *.ko.zst) zstd -qdc "$1" >"$2" ;;
    *.ko.gz) gzip -dc "$1" >"$2" ;;
    *) die "unknown module format $1" ;;
  esac
}
declare -A loaded=()
order=()
add_module() {  # depth-first: dependencies first
  local name="${1//-/_}" src dep deps tmp
  [ -n "${loaded[$name]:-}" ] && return 0
  src="${mod_path[$name]:-}"
  [ -n "$src" ] || die "kernel module $name not found under $moddir/kernel"
  loaded[$name]=1
  tmp="$root/lib/modules/$name.ko"
  plain_module "$src" "$tmp"
  deps="$(tr '\0' '\n' <"$tmp" | sed -n 's/^depends=//p' | head -n 1)"
  for dep in ${deps//,/ }; do add_module "$dep"; done
  order+=("$name")
}
for m in can can_raw can_dev vcan evdev uinput; do add_module "$m"; done
printf '%s\n' "${order[@]}" >"$root/etc/hil-modules"

# 3. can-utils (dynamically linked against libc).
for tool in candump cansend canplayer cangen; do
  src="$cache/root/can-utils/usr/bin/$tool"
  [ -x "$src" ] || die "$src missing"
  cp "$src" "$root/bin/$tool"
  copy_libs "$src"
done

# 4. iproute2's ip as a fallback for creating vcan links (busybox ip is tried first).
if [ -x /sbin/ip ] || [ -x /usr/sbin/ip ] || [ -x /bin/ip ]; then
  ipbin="$(command -v ip || true)"
  [ -n "$ipbin" ] || ipbin=/sbin/ip
  cp -L "$ipbin" "$root/bin/ip.iproute2"
  copy_libs "$ipbin"
fi

# 5. numen's HIL programs.
for prog in numen_hil_tests numen_hil_can; do
  cp "$build/tests/$prog" "$root/hil/bin/$prog"
  strip --strip-unneeded "$root/hil/bin/$prog" 2>/dev/null || true
  copy_libs "$build/tests/$prog"
done

# 5b. The numen command (numen run / numen device) with the lattice scene and its trajectory
# data at the same relative paths (the scene names ../data/...).
cp "$build/numen" "$root/hil/bin/numen"
strip --strip-unneeded "$root/hil/bin/numen" 2>/dev/null || true
copy_libs "$build/numen"
mkdir -p "$root/hil/sim/scenes" "$root/hil/sim/data"
cp "$repo/sim/scenes/lattice.toml" "$root/hil/sim/scenes/"
cp -r "$repo/sim/scenes/devices" "$root/hil/sim/scenes/"  # the scene's node DCFs
cp "$repo"/sim/data/*.txt "$root/hil/sim/data/"

# 6. /init, the scenario library and the scenarios.
cp "$here/init.sh" "$root/init"
cp "$here/lib.sh" "$root/hil/lib.sh"
cp "$here"/scenarios/*.sh "$root/hil/scenarios/"
chmod +x "$root/init" "$root"/hil/scenarios/*.sh

# 7. The archive: newc cpio, owned by root, gzip (the Debian kernel has CONFIG_RD_GZIP).
(cd "$root" && find . -mindepth 1 | LC_ALL=C sort | cpio -o -H newc -R 0:0 --quiet) |
  gzip -9 >"$out/initramfs.cpio.gz"
cp "$vmlinuz" "$out/vmlinuz"
echo "$kver" >"$out/kernel-version"
img_kib=$(( $(stat -c %s "$out/initramfs.cpio.gz") / 1024 ))
kern_kib=$(( $(stat -c %s "$out/vmlinuz") / 1024 ))
echo "build_image: kernel $kver (${kern_kib} KiB), initramfs ${img_kib} KiB, modules: ${order[*]}"
