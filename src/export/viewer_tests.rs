//! Tests of the viewer server: the request decision against a separate specification,
//! real sockets, the GLB check and the security headers.

use super::*;
use crate::export::gltf::{GltfFrame, GltfMaterial, SolutionGeometry};
use glam::DVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use std::io::{Read, Write};
use std::net::TcpStream;

/// A one-triangle solution written by daystep's own exporter: the files `view` serves.
fn daystep_glb() -> Vec<u8> {
    let corners = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let geometry = SolutionGeometry::new(
        &[(corners, DVec3::Z, 0.5, 0)],
        vec![GltfMaterial {
            name: "floor".into(),
            kd: DVec3::splat(0.5),
            glazing: false,
        }],
        DVec3::ZERO,
    );
    let frame = GltfFrame {
        label: "2024-03-21T12:00".into(),
        radiance: vec![DVec3::splat(10.0)],
        irradiance: vec![DVec3::splat(60.0)],
        sensor_lux: vec![],
    };
    geometry.encode(&[frame], &[]).unwrap()
}

/// A GLB built by hand from its parts (header fields as given, one chunk), so each
/// defect can be planted alone.
fn glb_of(
    magic: &[u8; 4],
    version: u32,
    declared: Option<u32>,
    chunk: u32,
    body: &[u8],
) -> Vec<u8> {
    let mut padded = body.to_vec();
    while padded.len() % 4 != 0 {
        padded.push(b' ');
    }
    let total = 12 + 8 + padded.len() as u32;
    let mut out = magic.to_vec();
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&declared.unwrap_or(total).to_le_bytes());
    out.extend_from_slice(&(padded.len() as u32).to_le_bytes());
    out.extend_from_slice(&chunk.to_le_bytes());
    out.extend_from_slice(&padded);
    out
}

const MINIMAL_JSON: &[u8] = br#"{"asset":{"version":"2.0"}}"#;

/// Sends `raw` (a whole request) and reads the response: (head, body bytes).
fn send(addr: SocketAddr, raw: &[u8]) -> (String, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(20)))
        .unwrap();
    s.write_all(raw).unwrap();
    let mut out = Vec::new();
    s.read_to_end(&mut out).unwrap();
    let split = out
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no response head in {:?}", String::from_utf8_lossy(&out)));
    let head = String::from_utf8_lossy(&out[..split]).into_owned();
    (head, out[split + 4..].to_vec())
}

/// An HTTP/1.0 `method` of `path` with the given `Host` headers (none: no Host at all).
fn request(addr: SocketAddr, method: &str, path: &str, hosts: &[&str]) -> (String, Vec<u8>) {
    let mut raw = format!("{method} {path} HTTP/1.0\r\n");
    for h in hosts {
        raw.push_str(&format!("Host: {h}\r\n"));
    }
    raw.push_str("\r\n");
    send(addr, raw.as_bytes())
}

/// A GET of `path` with the Host a browser sends for the printed URL.
fn get(addr: SocketAddr, path: &str) -> (String, Vec<u8>) {
    request(addr, "GET", path, &[&addr.to_string()])
}

/// Whether `body` holds a GLB header (magic and version 2), i.e. quotes the file.
fn quotes_a_glb(body: &[u8]) -> bool {
    body.windows(8).any(|w| w == b"glTF\x02\0\0\0")
}

/// The status code of a response head (tiny_http answers in the request's version).
fn status(head: &str) -> &str {
    head.split(' ').nth(1).unwrap_or("")
}

/// The value of header `name` in a response head (case-insensitive name), if any.
fn header_value<'a>(head: &'a str, name: &str) -> Option<&'a str> {
    head.lines().skip(1).find_map(|l| {
        let (n, v) = l.split_once(':')?;
        n.trim().eq_ignore_ascii_case(name).then(|| v.trim())
    })
}

/// A server on a free port for `name` holding `bytes`, answering on a thread; the
/// temporary folder must outlive the test.
fn start(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf, SocketAddr) {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join(name);
    std::fs::write(&glb, bytes).unwrap();
    let server = ViewerServer::bind(&glb, 0).unwrap();
    let addr = server.addr();
    std::thread::spawn(move || server.run());
    (dir, glb, addr)
}

#[test]
fn serves_the_page_and_the_glb_bytes() {
    let bytes = daystep_glb();
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("my room.glb");
    std::fs::write(&glb, &bytes).unwrap();
    let server = ViewerServer::bind(&glb, 0).unwrap();
    let addr = server.addr();
    assert!(
        server.url().ends_with("/?glb=my%20room.glb"),
        "{}",
        server.url()
    );
    std::thread::spawn(move || server.run());

    let (head, body) = get(addr, "/?glb=my%20room.glb");
    assert_eq!(status(&head), "200", "{head}");
    assert_eq!(body, VIEWER_HTML.as_bytes());
    let (head, body) = get(addr, "/my%20room.glb");
    assert_eq!(status(&head), "200", "{head}");
    assert!(head.contains("model/gltf-binary"), "{head}");
    assert_eq!(body, bytes);
    let (head, _) = get(addr, "/");
    assert_eq!(status(&head), "302", "{head}");
    assert!(head.contains("Location: /?glb=my%20room.glb"), "{head}");
    let (head, _) = get(addr, "/../secret.glb");
    assert_eq!(status(&head), "404", "{head}");
}

#[test]
fn a_foreign_host_header_is_refused_dns_rebinding() {
    let bytes = daystep_glb();
    let (_dir, _glb, addr) = start("room.glb", &bytes);
    let port = addr.port();
    let refused = [
        vec![format!("attacker.example:{port}")],
        vec!["attacker.example".to_owned()],
        vec![format!("127.0.0.1.attacker.example:{port}")],
        vec![format!("localhost.:{port}")],
        vec![format!("127.0.0.1:{}", port.wrapping_add(1))],
        vec![format!("127.0.0.1:0{port}")],
        vec!["127.0.0.1".to_owned()],
        vec![format!("0.0.0.0:{port}")],
        vec![format!("[::1]:{port}"), format!("attacker.example:{port}")],
        vec![format!("127.0.0.1:{port}"), format!("127.0.0.1:{port}")],
        vec![],
    ];
    for hosts in &refused {
        let hosts: Vec<&str> = hosts.iter().map(String::as_str).collect();
        for path in [
            "/room.glb",
            "/",
            "/?glb=room.glb",
            "/index.html",
            "/nothing",
        ] {
            for method in ["GET", "HEAD", "POST"] {
                let (head, body) = request(addr, method, path, &hosts);
                assert_eq!(
                    status(&head),
                    "403",
                    "{method} {path} Host {hosts:?}: {head}"
                );
                assert!(
                    !quotes_a_glb(&body) && body != VIEWER_HTML.as_bytes(),
                    "{method} {path} Host {hosts:?}: the body gives the file or page away"
                );
            }
        }
    }
    for host in [
        format!("127.0.0.1:{port}"),
        format!("LocalHost:{port}"),
        format!("[::1]:{port}"),
    ] {
        let (head, body) = request(addr, "GET", "/room.glb", &[&host]);
        assert_eq!(status(&head), "200", "Host {host}: {head}");
        assert_eq!(body, bytes, "Host {host}");
    }
    // The header's name is case-insensitive, its value's surrounding blanks optional.
    let raw =
        format!("GET /room.glb HTTP/1.1\r\nhOST:  localhost:{port} \r\nConnection: close\r\n\r\n");
    let (head, _) = send(addr, raw.as_bytes());
    assert_eq!(status(&head), "200", "{head}");
}

#[test]
fn paths_other_than_the_page_and_the_model_are_not_found() {
    let (dir, _glb, addr) = start("room.glb", &daystep_glb());
    std::fs::write(dir.path().join("scene.toml"), "secret").unwrap();
    for path in [
        "/scene.toml",
        "/other.glb",
        "/room.glb/",
        "//room.glb",
        "/./room.glb",
        "/../room.glb",
        "/%2e%2e/room.glb",
        "/%2Froom.glb",
        "/room.glb%00",
        "/room%2Eglb%",
        "/room.gl%+2",
        "/%FF",
        "/index.htm",
        "/viewer.html/",
        "/favicon.ico/",
        "http://127.0.0.1/room.glb",
        "*",
    ] {
        let (head, body) = get(addr, path);
        assert_eq!(status(&head), "404", "{path}: {head}");
        assert!(!quotes_a_glb(&body), "{path}");
        assert!(!body.windows(6).any(|w| w == b"secret"), "{path}");
    }
    for path in [
        "/",
        "/?glb=room.glb",
        "/index.html",
        "/viewer.html?x",
        "/room.glb",
        "/%72oom.glb",
        "/room.glb?v=2",
    ] {
        let (head, _) = get(addr, path);
        assert!(matches!(status(&head), "200" | "302"), "{path}: {head}");
    }
    // The icon browsers ask for on their own: nothing, and not a 404 in their console.
    for path in ["/favicon.ico", "/favicon.ico?v=1"] {
        let (head, body) = get(addr, path);
        assert_eq!(status(&head), "204", "{path}: {head}");
        assert!(body.is_empty(), "{path}");
    }
}

#[test]
fn every_response_carries_the_security_headers() {
    let (dir, glb, addr) = start("room.glb", &daystep_glb());
    let port = addr.port();
    let own = addr.to_string();
    let foreign = format!("attacker.example:{port}");
    let mut heads = vec![
        ("page", get(addr, "/?glb=room.glb").0),
        ("model", get(addr, "/room.glb").0),
        ("redirect", get(addr, "/").0),
        ("404", get(addr, "/nothing").0),
        ("403", request(addr, "GET", "/room.glb", &[&foreign]).0),
        ("405", request(addr, "POST", "/room.glb", &[&own]).0),
        ("HEAD", request(addr, "HEAD", "/room.glb", &[&own]).0),
    ];
    std::fs::write(&glb, b"no longer a glb").unwrap();
    heads.push(("409", get(addr, "/room.glb").0));
    std::fs::remove_file(&glb).unwrap();
    heads.push(("500", get(addr, "/room.glb").0));
    drop(dir);
    let expected = [
        "200", "200", "302", "404", "403", "405", "200", "409", "500",
    ];
    for ((what, head), code) in heads.iter().zip(expected) {
        assert_eq!(status(head), code, "{what}: {head}");
        for (name, value) in [
            ("X-Content-Type-Options", "nosniff"),
            ("Referrer-Policy", "no-referrer"),
            ("Cross-Origin-Resource-Policy", "same-origin"),
            ("Cache-Control", "no-store"),
        ] {
            assert_eq!(
                header_value(head, name),
                Some(value),
                "{what}: {name} in {head}"
            );
        }
        let csp = header_value(head, "Content-Security-Policy")
            .unwrap_or_else(|| panic!("{what}: no Content-Security-Policy in {head}"));
        let directives: Vec<&str> = csp.split(';').map(str::trim).collect();
        for d in [
            "default-src 'self'",
            "connect-src 'self'",
            "object-src 'none'",
            "base-uri 'none'",
            "frame-ancestors 'none'",
            "form-action 'none'",
        ] {
            assert!(directives.contains(&d), "{what}: no {d:?} in {csp}");
        }
        // CORS stays closed: no other origin may read a response.
        assert!(
            !head.to_ascii_lowercase().contains("access-control-"),
            "{what}: {head}"
        );
    }
}

#[test]
fn the_csp_allows_only_the_pages_own_inline_script_by_hash() {
    let csp = content_security_policy();
    let script_src = csp
        .split(';')
        .map(str::trim)
        .find_map(|d| d.strip_prefix("script-src "))
        .unwrap_or_else(|| panic!("no script-src in {csp}"));
    let sources: Vec<&str> = script_src.split(' ').collect();
    let scripts = inline_scripts(VIEWER_HTML);
    assert_eq!(scripts.len(), 1, "viewer.html has one inline script");
    assert_eq!(sources.len(), 1, "{script_src}");
    assert!(
        sources[0].starts_with("'sha256-") && sources[0].len() == 8 + 44 + 1,
        "{script_src}"
    );
    for bad in [
        "unsafe-eval",
        "unsafe-hashes",
        "*",
        "http:",
        "https:",
        "blob:",
        "data:",
    ] {
        assert!(!csp.contains(bad), "{bad:?} in {csp}");
    }
    assert!(!script_src.contains("unsafe-inline"), "{csp}");
    // The browser hashes the script's text after newline normalisation; a script with a
    // src has no inline text.
    assert_eq!(
        inline_scripts("<p><script>a\r\nb\rc</script><script src=\"x.js\"></script><script type=\"module\">d</script>"),
        ["a\nb\nc", "d"]
    );
}

/// The hash is SHA-256 as CSP defines it (one FIPS 180-4 example: the wiring, not
/// the crate, is what is checked here).
#[test]
fn sha256_is_the_fips_180_one() {
    let hex = |d: [u8; 32]| d.iter().map(|b| format!("{b:02x}")).collect::<String>();
    assert_eq!(
        hex(sha256(b"abc")),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
}

#[test]
fn methods_other_than_get_and_head_are_refused() {
    let bytes = daystep_glb();
    let (_dir, _glb, addr) = start("room.glb", &bytes);
    let own = addr.to_string();
    for method in [
        "POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "get", "BREW",
    ] {
        for path in ["/room.glb", "/", "/index.html", "/nothing"] {
            let (head, body) = request(addr, method, path, &[&own]);
            assert_eq!(status(&head), "405", "{method} {path}: {head}");
            assert_eq!(header_value(&head, "Allow"), Some("GET, HEAD"), "{head}");
            assert!(!quotes_a_glb(&body), "{method} {path}");
        }
    }
    let (head, body) = request(addr, "HEAD", "/room.glb", &[&own]);
    assert_eq!(status(&head), "200", "{head}");
    assert!(body.is_empty(), "HEAD sent {} bytes", body.len());
}

#[test]
fn a_file_that_is_not_a_glb_is_refused_at_bind() {
    let scene =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml"))
            .unwrap();
    let good = daystep_glb();
    let mut cut = good.clone();
    cut.truncate(good.len() - 4);
    let mut longer = good.clone();
    longer.extend_from_slice(b"    ");
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "scene.toml",
            scene,
            "does not start with the magic \"glTF\"",
        ),
        ("empty", vec![], "shorter than the 12-byte GLB header"),
        (
            "short",
            b"glTF\x02\0\0\0".to_vec(),
            "shorter than the 12-byte GLB header",
        ),
        (
            "magic",
            glb_of(b"gltf", 2, None, CHUNK_JSON, MINIMAL_JSON),
            "magic",
        ),
        (
            "version 1",
            glb_of(b"glTF", 1, None, CHUNK_JSON, MINIMAL_JSON),
            "GLB version 1",
        ),
        ("cut short", cut, "the GLB header declares"),
        ("trailing bytes", longer, "the GLB header declares"),
        (
            "header only",
            glb_of(b"glTF", 2, Some(12), CHUNK_JSON, b"")[..12].to_vec(),
            "no chunk",
        ),
        (
            "BIN first",
            glb_of(b"glTF", 2, None, 0x004E_4942, MINIMAL_JSON),
            "not of type JSON",
        ),
        (
            "chunk past the end",
            {
                let mut g = glb_of(b"glTF", 2, None, CHUNK_JSON, MINIMAL_JSON);
                g[12..16].copy_from_slice(&1000u32.to_le_bytes());
                g
            },
            "past the end of the file",
        ),
        (
            "JSON syntax",
            glb_of(b"glTF", 2, None, CHUNK_JSON, b"{\"asset\":"),
            "not valid glTF",
        ),
        (
            "not glTF JSON",
            glb_of(b"glTF", 2, None, CHUNK_JSON, b"{\"a\":1}"),
            "not valid glTF",
        ),
        (
            "dangling index",
            glb_of(
                b"glTF",
                2,
                None,
                CHUNK_JSON,
                br#"{"asset":{"version":"2.0"},"scene":3}"#,
            ),
            "not valid glTF",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (what, bytes, says) in cases {
        let path = dir.path().join(format!("{what}.glb"));
        std::fs::write(&path, &bytes).unwrap();
        let e = ViewerServer::bind(&path, 0)
            .err()
            .unwrap_or_else(|| panic!("{what}: served"));
        assert_eq!(e.exit_code(), 1, "{what}: {e}");
        let (shown, p, _, _) = crate::error::input_parts(e);
        assert_eq!(p, path, "{what}");
        assert!(
            shown.contains(says),
            "{what}: {shown:?} does not say {says:?}"
        );
    }
    // The hand-built minimal file and daystep's own are accepted.
    for (what, bytes) in [
        (
            "minimal",
            glb_of(b"glTF", 2, None, CHUNK_JSON, MINIMAL_JSON),
        ),
        ("daystep", good),
    ] {
        let path = dir.path().join(format!("{what}.glb"));
        std::fs::write(&path, &bytes).unwrap();
        assert!(ViewerServer::bind(&path, 0).is_ok(), "{what}");
    }
}

#[test]
fn a_glb_that_is_no_longer_valid_is_answered_without_its_bytes() {
    let good = daystep_glb();
    let (_dir, glb, addr) = start("room.glb", &good);
    // Half written by a re-export, or replaced by another kind of file.
    let mut half = good.clone();
    half.truncate(good.len() / 2);
    let mut other = b"SECRET-CONTENT ".repeat(10);
    other.extend_from_slice(&good);
    for (what, bytes) in [("half", half), ("other", other), ("empty", vec![])] {
        std::fs::write(&glb, &bytes).unwrap();
        let (head, body) = get(addr, "/room.glb");
        assert_eq!(status(&head), "409", "{what}: {head}");
        assert!(
            !quotes_a_glb(&body) && !body.windows(6).any(|w| w == b"SECRET"),
            "{what}: the body quotes the file"
        );
    }
    std::fs::write(&glb, &good).unwrap();
    let (head, body) = get(addr, "/room.glb");
    assert_eq!(status(&head), "200", "{head}");
    assert_eq!(body, good);
    std::fs::remove_file(&glb).unwrap();
    let (head, _) = get(addr, "/room.glb");
    assert_eq!(status(&head), "500", "{head}");
}

// ---------- the request decision under arbitrary input ----------

/// The specification of [`decide`], written independently: the Host set enumerated, the
/// path decoded by splitting on `%`.
fn expected(method: &str, hosts: &[&str], url: &str, port: u16, name: &str) -> Answer {
    let mut own: Vec<String> = LOOPBACK_NAMES
        .iter()
        .map(|n| format!("{n}:{port}"))
        .collect();
    if port == 80 {
        own.extend(LOOPBACK_NAMES.iter().map(|n| n.to_string()));
    }
    if hosts.len() != 1 || !own.contains(&hosts[0].to_ascii_lowercase()) {
        return Answer::ForeignHost;
    }
    if method != "GET" && method != "HEAD" {
        return Answer::MethodNotAllowed;
    }
    let (path, query) = match url.find('?') {
        Some(i) => (&url[..i], &url[i + 1..]),
        None => (url, ""),
    };
    match (path, query) {
        ("/", "") => return Answer::Redirect,
        ("/" | "/index.html" | "/viewer.html", _) => return Answer::Page,
        _ => {}
    }
    let Some(rest) = path.strip_prefix('/') else {
        return Answer::NotFound;
    };
    let mut pieces = rest.split('%');
    let mut bytes = pieces.next().unwrap_or("").as_bytes().to_vec();
    for piece in pieces {
        let mut cs = piece.chars();
        let (Some(h), Some(l)) = (
            cs.next().and_then(|c| c.to_digit(16)),
            cs.next().and_then(|c| c.to_digit(16)),
        ) else {
            return Answer::NotFound;
        };
        bytes.push((h * 16 + l) as u8);
        bytes.extend_from_slice(&piece.as_bytes()[2..]);
    }
    if bytes == name.as_bytes() {
        Answer::Model
    } else if path == "/favicon.ico" {
        Answer::NoIcon
    } else {
        Answer::NotFound
    }
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(0x0064_6179_7374_6570),
        ..Config::default()
    })
}

/// `name` with each byte percent-encoded or not (`%` and `?` always), hex in either case.
fn encodings(name: String) -> impl Strategy<Value = (String, String)> {
    let n = name.len();
    proptest::collection::vec((any::<bool>(), any::<bool>()), n).prop_map(move |choice| {
        let mut s = String::new();
        for (b, (encode, lower)) in name.bytes().zip(choice) {
            if encode || b == b'%' || b == b'?' || !b.is_ascii() {
                let e = format!("%{b:02X}");
                s.push_str(&if lower { e.to_ascii_lowercase() } else { e });
            } else {
                s.push(b as char);
            }
        }
        (name.clone(), s)
    })
}

fn name_strategy() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("room.glb".to_owned()),
        "[a-zA-Z0-9 %?#+&=._~-]{1,20}\\.glb",
        "[^/\u{0}]{1,12}\\.glb",
    ]
}

fn host_strategy(port: u16) -> impl Strategy<Value = String> {
    let names = || 0..LOOPBACK_NAMES.len();
    prop_oneof![
        // Own, in any letter case.
        4 => (names(), any::<u64>()).prop_map(move |(i, bits)| {
            LOOPBACK_NAMES[i]
                .chars()
                .enumerate()
                .map(|(k, c)| if bits >> (k % 64) & 1 == 1 { c.to_ascii_uppercase() } else { c })
                .collect::<String>()
                + &format!(":{port}")
        }),
        // A loopback name with any port, or none.
        1 => (names(), any::<u16>()).prop_map(|(i, p)| format!("{}:{p}", LOOPBACK_NAMES[i])),
        1 => names().prop_map(|i| LOOPBACK_NAMES[i].to_owned()),
        // Own, with something before or after it.
        1 => (names(), "[ .:a-z0-9\\[\\]%-]{0,4}", "[ .:a-z0-9\\[\\]%-]{0,4}")
            .prop_map(move |(i, pre, post)| format!("{pre}{}:{port}{post}", LOOPBACK_NAMES[i])),
        1 => Just(format!("attacker.example:{port}")),
        1 => "[a-z0-9.-]{1,30}(:[0-9]{1,6})?",
        1 => "\\PC{0,40}",
        1 => ".{0,5000}",
    ]
}

fn url_strategy(name: String) -> impl Strategy<Value = String> {
    let path = prop_oneof![
        Just("/".to_owned()),
        Just("/index.html".to_owned()),
        Just("/viewer.html".to_owned()),
        encodings(name.clone()).prop_map(|(_, e)| format!("/{e}")),
        // The name behind extra slashes or dot segments: another path, not the model.
        (
            "/{1,3}",
            "(\\./|\\.\\./|%2[eE]%2[eE]/)?",
            encodings(name.clone())
        )
            .prop_map(|(slashes, dots, (_, e))| format!("{slashes}{dots}{e}")),
        (
            encodings(name),
            "(/|\\.\\.|%2e|%2E|%2f|%5c|%00|%|\\.|%%|%F|%ff|%C0%AF)*",
            "(/|\\.\\.|%2e|%2f|%00|%|\\.|%FF|%fe%ff)*"
        )
            .prop_map(|((_, e), pre, post)| format!("{pre}/{e}{post}")),
        "(/|%[0-9A-Fa-f]{2}|%[G-Zg-z+-]{0,2}|[a-z.~]){0,40}",
        "/\\PC{0,200}",
        "/[a-z%./]{1000,20000}",
        ".{0,100}",
    ];
    let query = prop_oneof![
        Just(String::new()),
        Just("?".to_owned()),
        "\\?\\PC{0,30}",
        "\\?glb=[a-z.%]{0,20}",
    ];
    (path, query).prop_map(|(p, q)| p + &q)
}

fn method_strategy() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => Just("GET".to_owned()),
        2 => Just("HEAD".to_owned()),
        1 => Just("POST".to_owned()),
        1 => Just("OPTIONS".to_owned()),
        1 => Just("get".to_owned()),
        1 => "[A-Z]{1,8}",
    ]
}

/// Cases of the arbitrary-request property.
const ARBITRARY_CASES: u32 = 20_000;
/// Cases of the own-origin property.
const OWN_CASES: u32 = 5_000;

#[test]
fn arbitrary_requests_get_the_page_or_model_only_with_the_own_host() {
    let port_strategy = prop_oneof![Just(80u16), Just(8765u16), 1u16..];
    let strategy = (port_strategy, name_strategy()).prop_flat_map(|(port, name)| {
        (
            Just(port),
            Just(name.clone()),
            method_strategy(),
            prop_oneof![
                3 => proptest::collection::vec(host_strategy(port), 1),
                1 => proptest::collection::vec(host_strategy(port), 0..3),
            ],
            url_strategy(name),
        )
    });
    let served = std::cell::Cell::new(0usize);
    runner(ARBITRARY_CASES)
        .run(&strategy, |(port, name, method, hosts, url)| {
            let hosts: Vec<&str> = hosts.iter().map(String::as_str).collect();
            let got = decide(&method, &hosts, &url, port, &name);
            let want = expected(&method, &hosts, &url, port, &name);
            prop_assert_eq!(
                got,
                want,
                "{} {:?} Host {:?} port {} name {:?}",
                method,
                url,
                hosts,
                port,
                name
            );
            if matches!(got, Answer::Page | Answer::Model | Answer::Redirect) {
                served.set(served.get() + 1);
            }
            Ok(())
        })
        .unwrap();
    // The strategies reach the served answers too, not only refusals.
    let served = served.get();
    assert!(
        served > ARBITRARY_CASES as usize / 50,
        "only {served} served"
    );
}

#[test]
fn every_encoding_of_the_name_from_the_own_host_gets_the_model() {
    let strategy = (1u16.., name_strategy()).prop_flat_map(|(port, name)| {
        (
            Just(port),
            encodings(name),
            host_strategy(port).prop_filter("own", move |h| {
                LOOPBACK_NAMES
                    .iter()
                    .any(|n| h.eq_ignore_ascii_case(&format!("{n}:{port}")))
            }),
            prop_oneof![Just("GET"), Just("HEAD")],
            "(\\?\\PC{0,20})?",
        )
    });
    runner(OWN_CASES)
        .run(&strategy, |(port, (name, encoded), host, method, query)| {
            let url = format!("/{encoded}{query}");
            let got = decide(method, &[&host], &url, port, &name);
            if got != Answer::Model {
                return Err(TestCaseError::fail(format!(
                    "{url:?} for {name:?} from {host}: {got:?}"
                )));
            }
            Ok(())
        })
        .unwrap();
}

/// Real requests with random Host values and paths: the server's answer is the one
/// [`decide`]'s specification gives, so the header parsing in between changes nothing.
#[test]
fn random_requests_over_a_socket_get_the_specified_status() {
    let (_dir, _glb, addr) = start("room.glb", &daystep_glb());
    let port = addr.port();
    let host = prop_oneof![
        Just(format!("127.0.0.1:{port}")),
        Just(format!("LOCALHOST:{port}")),
        Just(format!("attacker.example:{port}")),
        "[!-~]{0,30}",
    ];
    let path = prop_oneof![
        Just("/room.glb".to_owned()),
        Just("/".to_owned()),
        Just("/index.html".to_owned()),
        "/(%[0-9a-fA-F]{2}|[!-~]){0,30}",
    ];
    runner(SOCKET_CASES)
        .run(&(host, path), |(host, path)| {
            let (head, _) = request(addr, "GET", &path, &[&host]);
            let want = match expected("GET", &[host.trim()], &path, port, "room.glb") {
                Answer::Page | Answer::Model => "200",
                Answer::Redirect => "302",
                Answer::NoIcon => "204",
                Answer::NotFound => "404",
                Answer::ForeignHost => "403",
                Answer::MethodNotAllowed => "405",
            };
            prop_assert_eq!(
                status(&head),
                want,
                "GET {} Host {:?}: {}",
                path,
                host,
                head
            );
            Ok(())
        })
        .unwrap();
}

/// Cases of the socket property (one connection each).
const SOCKET_CASES: u32 = 300;

#[test]
fn refuses_a_missing_file() {
    let e = ViewerServer::bind(Path::new("/nonexistent/x.glb"), 0)
        .err()
        .unwrap();
    assert_eq!(e.exit_code(), 1);
}

#[test]
fn the_page_uses_no_network() {
    for bad in [
        "http://",
        "https://",
        "//cdn",
        "<link ",
        "@import",
        "src=\"http",
    ] {
        assert!(!VIEWER_HTML.contains(bad), "viewer.html contains {bad:?}");
    }
}
