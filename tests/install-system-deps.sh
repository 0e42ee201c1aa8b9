#!/usr/bin/env bash
# Debian packages the tests need: Mesa's software Vulkan driver (lavapipe) and the Vulkan loader,
# so the wgpu path of fDED has an adapter to run on, and Chromium, which the cross-check group's
# report check (tests/crosscheck/check_report.sh) runs headless to screenshot `cowork report`'s
# index.html, and the openssl command, with which `cowork keystore` writes DDS Security keystores
# (nodes/lib/ros/tests/security.rs), and libssl-dev + pkg-config, with which the secured peer of
# tests/crosscheck/check_secure.sh builds (RustDDS security). Idempotent; needs root (or sudo).
set -euo pipefail
packages=(mesa-vulkan-drivers libvulkan1 chromium openssl libssl-dev pkg-config)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "system deps: ${packages[*]} already installed"
  exit 0
fi
sudo=()
[[ $(id -u) -ne 0 ]] && sudo=(sudo)
echo "system deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
