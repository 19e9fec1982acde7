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

/// The request decision under arbitrary input.
#[path = "viewer_decide_tests.rs"]
mod decide;
