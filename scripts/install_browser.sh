#!/usr/bin/env bash
# Installs the headless browser the explorer tests drive (tests/test_explore_browser.py):
# Debian's `chromium`, through apt, when no Chromium is on PATH. Never fails the caller: where
# apt is missing or the install fails (no root, no network), it says so and the browser tests
# are skipped with that reason.
set -u
for name in chromium chromium-browser google-chrome; do
    if command -v "$name" >/dev/null 2>&1; then
        exit 0
    fi
done
if ! command -v apt-get >/dev/null 2>&1; then
    echo "install_browser.sh: no chromium and no apt-get: the browser tests will be skipped" >&2
    exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        SUDO="sudo -n"
    else
        echo "install_browser.sh: not root and no sudo: cannot install chromium;" \
            "the browser tests will be skipped" >&2
        exit 0
    fi
fi
echo "install_browser.sh: installing chromium (apt-get)" >&2
if ! { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium; } >/dev/null 2>&1; then
    echo "install_browser.sh: apt-get could not install chromium: the browser tests will be skipped" >&2
fi
exit 0
