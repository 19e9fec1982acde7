//! The `.glb` solution viewer (`daystep view`): one self-contained HTML page (WebGL, no
//! network access; `assets/viewer.html`) and a tiny HTTP server on 127.0.0.1 that serves it
//! with one `.glb` file.
//!
//! The page also works opened straight from disk (`file://`, the file picked or dropped);
//! the server exists because browsers refuse `fetch` of a local file from a `file://`
//! page, so `?glb=NAME.glb` needs an http origin.
//!
//! Routes: `/` without a query redirects to `/?glb=NAME.glb`; `/`, `/index.html` and
//! `/viewer.html` give the page; `/NAME.glb` gives the file, read again on every request so
//! a re-exported solution shows on reload; anything else is 404.
//!
//! The model is often a client's confidential building, so the server answers only its own
//! origin: a request whose `Host` is not `127.0.0.1:PORT`, `localhost:PORT` or
//! `[::1]:PORT` is refused (403; DNS rebinding), only GET and HEAD are answered (405), and
//! every response forbids sniffing, framing, cross-origin embedding and any script but
//! the page's own. The threat model is `docs/viewer-server.md`.

use crate::error::{Error, Result};
use base64::Engine;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// The viewer page, embedded so the binary serves it without any installed files.
pub const VIEWER_HTML: &str = include_str!("../../assets/viewer.html");

/// A bound viewer server; [`ViewerServer::run`] answers requests.
pub struct ViewerServer {
    server: tiny_http::Server,
    glb: PathBuf,
    name: String,
    /// The bound port, which every accepted `Host` header must name.
    port: u16,
    /// The `Content-Security-Policy` value of every response ([`content_security_policy`]).
    csp: String,
}

/// What one request gets, decided from its method, `Host` headers and URL alone
/// ([`decide`]), so that every request the server can receive can be checked fast.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Answer {
    /// 200 with the page.
    Page,
    /// 302 to `/?glb=NAME`.
    Redirect,
    /// 200 with the `.glb` if it is still a valid glTF binary when read, else 409 (500 when
    /// it cannot be read).
    Model,
    /// 404: any other path.
    NotFound,
    /// 403: no `Host`, several, or one that is not this server's own origin (a page from
    /// another site whose name was made to resolve to 127.0.0.1: DNS rebinding).
    ForeignHost,
    /// 405: a method other than GET and HEAD.
    MethodNotAllowed,
}

/// The names a `Host` header may give (compared ASCII-case-insensitively), each followed by
/// `:PORT`.
const LOOPBACK_NAMES: [&str; 3] = ["127.0.0.1", "localhost", "[::1]"];

/// Whether `host` (one `Host` header's value) names this server: a loopback name and the
/// bound `port`. Browsers omit the port of `http:` when it is 80, so there the bare name is
/// this origin too.
fn host_is_own(host: &str, port: u16) -> bool {
    let loopback = |name: &str| LOOPBACK_NAMES.iter().any(|n| n.eq_ignore_ascii_case(name));
    if port == 80 && loopback(host) {
        return true;
    }
    match host.rsplit_once(':') {
        Some((name, p)) => p == port.to_string() && loopback(name),
        None => false,
    }
}

/// The answer to a request with `method`, the values of its `Host` headers (`hosts`, in
/// order) and request target `url` (path and query), for a server bound to `port` serving
/// the file called `name`. The Host is checked before anything else so that a foreign
/// origin learns nothing, not even which paths exist.
pub(crate) fn decide(method: &str, hosts: &[&str], url: &str, port: u16, name: &str) -> Answer {
    match hosts {
        [host] if host_is_own(host, port) => {}
        _ => return Answer::ForeignHost,
    }
    if !matches!(method, "GET" | "HEAD") {
        return Answer::MethodNotAllowed;
    }
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    if path == "/" && query.is_empty() {
        return Answer::Redirect;
    }
    if matches!(path, "/" | "/index.html" | "/viewer.html") {
        return Answer::Page;
    }
    // The name is compared whole after decoding, and a file name has no `/`, so no escape,
    // `..` or extra segment can reach any other file.
    let decoded = path.strip_prefix('/').and_then(percent_decode);
    if decoded.as_deref() == Some(name) {
        return Answer::Model;
    }
    Answer::NotFound
}

/// `name` with everything outside RFC 3986's unreserved set percent-encoded, so any file
/// name survives as one URL path segment and query value.
fn percent_encode(name: &str) -> String {
    let mut s = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            s.push(b as char);
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

/// The inverse of [`percent_encode`] (also of any browser's encoding); `None` for a
/// malformed escape or non-UTF-8 result.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            // from_str_radix takes a leading sign, which is no hex digit.
            if !hex.bytes().all(|c| c.is_ascii_hexdigit()) {
                return None;
            }
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// What is wrong with a file that is not a glTF binary: the offending value, where there is
/// one, and a message naming it.
#[derive(Debug)]
struct NotGlb {
    value: Option<String>,
    message: String,
}

impl NotGlb {
    fn new(value: Option<String>, message: impl Into<String>) -> NotGlb {
        NotGlb {
            value,
            message: message.into(),
        }
    }
}

/// `JSON` as a GLB chunk type (little-endian u32).
const CHUNK_JSON: u32 = 0x4E4F_534A;

/// Checks that `bytes` is a glTF 2.0 binary: magic `glTF`, version 2, the declared length
/// equal to the file's, a first chunk of type JSON inside the file, and a whole that the
/// gltf crate parses and validates.
fn check_glb(bytes: &[u8]) -> std::result::Result<(), NotGlb> {
    let u32_at = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let shown = |at: usize| bytes.get(at..at + 4).map(|b| b.escape_ascii().to_string());
    let (Some(version), Some(declared)) = (u32_at(4), u32_at(8)) else {
        return Err(NotGlb::new(
            Some(bytes.len().to_string()),
            format!(
                "not a glTF binary (.glb): {} bytes, shorter than the 12-byte GLB header",
                bytes.len()
            ),
        ));
    };
    if &bytes[..4] != b"glTF" {
        return Err(NotGlb::new(
            shown(0),
            "not a glTF binary (.glb): it does not start with the magic \"glTF\"",
        ));
    }
    if version != 2 {
        return Err(NotGlb::new(
            Some(version.to_string()),
            format!("GLB version {version}; only glTF 2.0 binaries (version 2) are read"),
        ));
    }
    if declared as usize != bytes.len() {
        return Err(NotGlb::new(
            Some(declared.to_string()),
            format!(
                "the GLB header declares {declared} bytes but the file has {} (cut short or still being written?)",
                bytes.len()
            ),
        ));
    }
    let (Some(chunk_len), Some(chunk_type)) = (u32_at(12), u32_at(16)) else {
        return Err(NotGlb::new(None, "the GLB has no chunk after its header"));
    };
    if chunk_type != CHUNK_JSON {
        return Err(NotGlb::new(
            shown(16),
            "the GLB's first chunk is not of type JSON",
        ));
    }
    if chunk_len as usize > bytes.len() - 20 {
        return Err(NotGlb::new(
            Some(chunk_len.to_string()),
            format!(
                "the GLB's JSON chunk declares {chunk_len} bytes, past the end of the file ({} after the chunk header)",
                bytes.len() - 20
            ),
        ));
    }
    ::gltf::Gltf::from_slice(bytes)
        .map(|_| ())
        .map_err(|e| NotGlb::new(None, format!("the GLB's JSON is not valid glTF: {e}")))
}

/// SHA-256 of `data`, for the Content-Security-Policy's script hash.
fn sha256(data: &[u8]) -> [u8; 32] {
    use sha2::Digest;
    sha2::Sha256::digest(data).into()
}

/// The text of every inline `<script>` element of `html` (those without `src`), as the
/// browser hashes it: after HTML's newline normalisation (CR LF and lone CR become LF).
fn inline_scripts(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(open) = rest.find("<script") {
        let after = &rest[open + "<script".len()..];
        let Some(tag_end) = after.find('>') else {
            break;
        };
        let attributes = &after[..tag_end];
        let body = &after[tag_end + 1..];
        let Some(close) = body.find("</script>") else {
            break;
        };
        if !attributes.contains("src") {
            out.push(body[..close].replace("\r\n", "\n").replace('\r', "\n"));
        }
        rest = &body[close..];
    }
    out
}

/// The `Content-Security-Policy` of every response: the page's own origin only
/// (`default-src 'self'`, `connect-src 'self'` for its `fetch` of the `.glb`); scripts only
/// the page's inline ones, by SHA-256 hash (not `'unsafe-inline'`, so no injected script
/// runs); inline styles (its `<style>` and two `style` attributes; CSS runs no script); no
/// plugins, `<base>`, framing or form submission. The page uses no images, fonts, workers,
/// `blob:` or `data:` URLs, so none are allowed beyond `default-src`.
pub(crate) fn content_security_policy() -> String {
    let b64 = base64::engine::general_purpose::STANDARD;
    let scripts: Vec<String> = inline_scripts(VIEWER_HTML)
        .iter()
        .map(|s| format!("'sha256-{}'", b64.encode(sha256(s.as_bytes()))))
        .collect();
    format!(
        "default-src 'self'; script-src {}; style-src 'unsafe-inline'; connect-src 'self'; \
         object-src 'none'; base-uri 'none'; frame-ancestors 'none'; form-action 'none'",
        scripts.join(" ")
    )
}

fn header(name: &str, value: &str) -> tiny_http::Header {
    // Only fixed ASCII names and values reach here, which tiny_http always accepts.
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes())
        .unwrap_or_else(|()| unreachable!("ASCII header {name}"))
}

/// A plain-text response of `status` with `text`.
fn text(status: u16, text: &str) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    tiny_http::Response::from_string(text)
        .with_status_code(status)
        .with_header(header("Content-Type", "text/plain; charset=utf-8"))
}

impl ViewerServer {
    /// Binds 127.0.0.1:`port` (0: any free port) to serve the viewer with `glb`.
    ///
    /// # Errors
    /// [`Error::Io`] when `glb` cannot be read; [`Error::Input`] when it is not a file, not
    /// a glTF 2.0 binary (magic, version, length, JSON chunk) or its name is not UTF-8, or
    /// when the port cannot be bound (in use, not permitted).
    pub fn bind(glb: &Path, port: u16) -> Result<ViewerServer> {
        let meta = std::fs::metadata(glb).map_err(|e| Error::io(glb, e))?;
        if !meta.is_file() {
            return Err(Error::input(glb, None, None, "not a file"));
        }
        let bytes = std::fs::read(glb).map_err(|e| Error::io(glb, e))?;
        check_glb(&bytes).map_err(|e| Error::input(glb, None, e.value.as_deref(), e.message))?;
        let name = glb
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| Error::input(glb, None, None, "the file name is not UTF-8"))?
            .to_owned();
        let server = tiny_http::Server::http(("127.0.0.1", port)).map_err(|e| {
            Error::input(
                format!("127.0.0.1:{port}"),
                None,
                None,
                format!("cannot listen there ({e}); choose another port"),
            )
        })?;
        let mut this = ViewerServer {
            server,
            glb: glb.to_path_buf(),
            name,
            port,
            csp: content_security_policy(),
        };
        this.port = this.addr().port();
        Ok(this)
    }

    /// The bound address (the actual port when bound with port 0).
    pub fn addr(&self) -> SocketAddr {
        match self.server.server_addr() {
            tiny_http::ListenAddr::IP(a) => a,
            #[allow(unreachable_patterns)]
            _ => unreachable!("bound to an IP address"),
        }
    }

    /// The page's URL with the `.glb` in its query, for the user to open.
    pub fn url(&self) -> String {
        format!("http://{}/?glb={}", self.addr(), percent_encode(&self.name))
    }

    /// The response for `answer`, with the headers every response carries.
    fn respond(&self, answer: Answer) -> tiny_http::ResponseBox {
        let response = match answer {
            Answer::Redirect => {
                let to = format!("/?glb={}", percent_encode(&self.name));
                tiny_http::Response::empty(302)
                    .with_header(header("Location", &to))
                    .boxed()
            }
            Answer::Page => tiny_http::Response::from_string(VIEWER_HTML)
                .with_header(header("Content-Type", "text/html; charset=utf-8"))
                .boxed(),
            Answer::Model => self.model().boxed(),
            Answer::NotFound => text(404, "not found").boxed(),
            Answer::ForeignHost => text(
                403,
                "forbidden: this server answers only Host 127.0.0.1, localhost or [::1] \
                 with its own port",
            )
            .boxed(),
            Answer::MethodNotAllowed => text(405, "method not allowed: GET and HEAD only")
                .with_header(header("Allow", "GET, HEAD"))
                .boxed(),
        };
        response
            .with_header(header("X-Content-Type-Options", "nosniff"))
            .with_header(header("Content-Security-Policy", &self.csp))
            .with_header(header("Referrer-Policy", "no-referrer"))
            .with_header(header("Cross-Origin-Resource-Policy", "same-origin"))
            .with_header(header("Cache-Control", "no-store"))
    }

    /// The `.glb`, read now so a re-exported solution shows on reload; 409 when it is no
    /// longer a glTF binary (say, half written), 500 when it cannot be read. Neither
    /// carries any of the file's bytes, nor the gltf crate's message, which may quote them.
    fn model(&self) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
        match std::fs::read(&self.glb) {
            Ok(bytes) => match check_glb(&bytes) {
                Ok(()) => tiny_http::Response::from_data(bytes)
                    .with_header(header("Content-Type", "model/gltf-binary")),
                Err(_) => text(
                    409,
                    "the .glb is no longer a valid glTF binary (being re-exported?); reload when it is written",
                ),
            },
            Err(e) => text(500, &format!("cannot read the .glb: {}", e.kind())),
        }
    }

    /// Answers requests until the process ends (Ctrl-C) or the listener fails.
    ///
    /// # Errors
    /// [`Error::Io`] when the listening socket fails.
    pub fn run(self) -> Result<()> {
        loop {
            let request = self
                .server
                .recv()
                .map_err(|e| Error::io(self.addr().to_string(), e))?;
            let hosts: Vec<&str> = request
                .headers()
                .iter()
                .filter(|h| h.field.equiv("Host"))
                .map(|h| h.value.as_str())
                .collect();
            let answer = decide(
                request.method().as_str(),
                &hosts,
                request.url(),
                self.port,
                &self.name,
            );
            let response = self.respond(answer);
            // A client that went away mid-response is its business, not the server's.
            let _ = request.respond(response);
        }
    }
}

/// Serves the viewer with `glb` on 127.0.0.1:`port` (0: any free port) until the process
/// ends; [`ViewerServer`] gives the URL first.
///
/// # Errors
/// As [`ViewerServer::bind`] and [`ViewerServer::run`].
pub fn serve(glb: &Path, port: u16) -> Result<()> {
    ViewerServer::bind(glb, port)?.run()
}

#[cfg(test)]
mod tests {
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
        let raw = format!(
            "GET /room.glb HTTP/1.1\r\nhOST:  localhost:{port} \r\nConnection: close\r\n\r\n"
        );
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
            "/favicon.ico",
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
}
