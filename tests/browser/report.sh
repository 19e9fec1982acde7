#!/usr/bin/env bash
# Headless-Chromium test of report.html (src/export/report_page.rs). Not part of `cargo
# test`: it installs Debian's chromium (apt-get, when /usr/bin/chromium is missing) and uses
# only chromium's own --screenshot / --dump-dom / --log-net-log and python3's standard
# library (report_check.py).
#
#     tests/browser/report.sh
#
# Runs `daystep annual` on scenes/office (four June days, draft) and on scenes/honeybee (one
# day, two grids), opens each report.html from its file and checks:
#   - the DOM: a Content-Security-Policy of default-src 'none', one section of three maps
#     per grid in the order of the summary table, each row linking to its own grid's maps;
#   - the office screenshot (target/browser-test/report-office.png): the first map's box
#     is not blank (luminance variance) and every legend colour is drawn in it, as are the
#     point classes the DOM gives;
#   - Chromium's network log while showing the page: no request made by the page (Chromium's
#     own background requests, initiator "not an origin", are not the page's);
#   - the policy works: a copy of the page with an <img> to a local server makes no request
#     to it (server and network log), while the same copy without the policy does (the
#     control, which also shows that the log check sees a page's request).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$root/target/browser-test"
target="${CARGO_TARGET_DIR:-$root/target}"
mkdir -p "$out"

if [[ ! -x /usr/bin/chromium ]]; then
    sudo_=""; [[ $(id -u) -ne 0 ]] && sudo_="sudo"
    $sudo_ apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y -qq chromium >/dev/null
fi
chrome=(/usr/bin/chromium --headless --no-sandbox --disable-gpu --hide-scrollbars
    --force-color-profile=srgb --force-device-scale-factor=1 --disable-background-networking
    --no-first-run --no-default-browser-check)

cd "$root"
cargo build -j 1 --quiet --bin daystep
daystep="$target/debug/daystep"
run() { # scene out start end [more flags]
    rm -rf "$2"
    "$daystep" annual "$1" --weather scenes/office/weather.epw --out "$2" --start "$3" \
        --end "$4" --quality draft --no-cache "${@:5}" 2>&1 | tail -n1
}
# The office with --leed: the page has its LEED table and blind heat map too.
run scenes/office/scene.toml "$out/office" 2026-06-20 2026-06-23 --leed
run scenes/honeybee/scene.toml "$out/honeybee" 2026-01-20 2026-01-20

for s in office honeybee; do
    page="$out/$s/report.html"
    [[ -s "$page" ]] || { echo "FAIL: $page not written"; exit 1; }
    echo "== $s: $page ($(wc -c <"$page") bytes)"
    "${chrome[@]}" --dump-dom "file://$page" 2>/dev/null >"$out/report-$s.dom.html"
    python3 "$here/report_check.py" dom "$out/report-$s.dom.html"
done

echo "== office: screenshot and network log"
rm -f "$out/report-office.png" "$out/netlog.json"
"${chrome[@]}" --window-size=1200,1000 --screenshot="$out/report-office.png" \
    --log-net-log="$out/netlog.json" --net-log-capture-mode=Everything \
    "file://$out/office/report.html" 2>/dev/null >/dev/null
[[ -s "$out/report-office.png" ]] || { echo "FAIL: no screenshot"; exit 1; }
echo "screenshot: $out/report-office.png"
python3 "$here/report_check.py" pixels "$out/report-office.png" "$out/report-office.dom.html"
python3 "$here/report_check.py" netlog "$out/netlog.json"

echo "== the Content-Security-Policy blocks a request (control: without it, one is made)"
port_file="$out/probe.port"
hits="$out/probe.hits"
rm -f "$port_file" "$hits"
python3 - "$port_file" "$hits" <<'EOF' &
import http.server, sys
port_file, hits = sys.argv[1], sys.argv[2]
class H(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        open(hits, "a").write(self.path + "\n")
        self.send_response(404)
        self.end_headers()
    def log_message(self, *a):
        pass
s = http.server.HTTPServer(("127.0.0.1", 0), H)
open(port_file, "w").write(str(s.server_port))
s.serve_forever()
EOF
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
for _ in $(seq 50); do [[ -s "$port_file" ]] && break; sleep 0.1; done
port="$(cat "$port_file")"
probe="<img src=\"http://127.0.0.1:$port/probe-PAGE.png\" alt=\"\">"
sed "s|<h1>|${probe//PAGE/with-csp}<h1>|" "$out/office/report.html" >"$out/probe-with-csp.html"
sed -e "s|<h1>|${probe//PAGE/without-csp}<h1>|" -e '/Content-Security-Policy/d' \
    "$out/office/report.html" >"$out/probe-without-csp.html"
for p in with-csp without-csp; do
    "${chrome[@]}" --dump-dom --log-net-log="$out/netlog-$p.json" \
        --net-log-capture-mode=Everything "file://$out/probe-$p.html" 2>/dev/null >/dev/null
done
python3 "$here/report_check.py" netlog "$out/netlog-with-csp.json"
python3 "$here/report_check.py" netlog "$out/netlog-without-csp.json" probe-without-csp.png
touch "$hits"
if grep -q with-csp.png "$hits"; then
    echo "FAIL: the page with its policy fetched the probe"; exit 1
fi
if ! grep -q without-csp.png "$hits"; then
    echo "FAIL: control: the page without the policy did not fetch the probe (test broken)"
    exit 1
fi
echo "ok: probe <img> blocked by the page's policy; fetched once the policy is removed"
echo "all report.html browser checks passed"
