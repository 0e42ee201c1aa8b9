#!/usr/bin/env bash
# Debian packages the tests need: Mesa's software Vulkan driver (lavapipe) and the Vulkan loader,
# so the wgpu path of fDED has an adapter to run on, and Chromium, which the cross-check group's
# report check (tests/crosscheck/check_report.sh) runs headless to screenshot `cowork report`'s
# index.html, and the openssl command, with which `cowork keystore` writes DDS Security keystores
# (nodes/lib/ros/tests/security.rs), and libssl-dev + pkg-config, with which the secured peer of
# tests/crosscheck/check_secure.sh builds (RustDDS security), and Node.js with npm, with which
# tests/crosscheck/check_bridge.sh runs Foxglove's own client packages against `cowork bridge`
# (only when no `node`/`npm` is on PATH: a NodeSource or nvm install is kept). Idempotent; needs
# root (or sudo).
set -euo pipefail
packages=(mesa-vulkan-drivers libvulkan1 chromium openssl libssl-dev pkg-config)
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi
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
