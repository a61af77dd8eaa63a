#!/usr/bin/env bash
# Checks a bench report (`penumbra bench` writes OUT/index.html) in a real headless browser:
# every image decodes and every link resolves. Needs Chromium (Debian: apt install chromium)
# and playwright-core (npm install --prefix "$PLAYWRIGHT_PREFIX" playwright-core).
#   scripts/check-report.sh [OUT]        (default out/bench)
set -euo pipefail
dir=${1:-out/bench}
prefix=${PLAYWRIGHT_PREFIX:-$HOME/.cache/penumbra-playwright}
browser=${CHROMIUM:-$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)}
if [[ -z "$browser" ]]; then
    echo "check-report: no Chromium found (apt install chromium, or set CHROMIUM)" >&2
    exit 2
fi
if [[ ! -d "$prefix/node_modules/playwright-core" ]]; then
    echo "check-report: installing playwright-core into $prefix" >&2
    npm install --silent --prefix "$prefix" playwright-core >&2
fi
[[ -f "$dir/index.html" ]] || { echo "check-report: $dir/index.html: no such file" >&2; exit 2; }
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
python3 -m http.server "$port" --bind 127.0.0.1 --directory "$dir" >/dev/null 2>&1 &
server=$!
trap 'kill $server 2>/dev/null' EXIT
for _ in $(seq 50); do
    python3 -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:$port/')" 2>/dev/null && break
    sleep 0.1
done
NODE_PATH="$prefix/node_modules" node "$(dirname "$0")/check-report.cjs" "http://127.0.0.1:$port/index.html" "$browser"
