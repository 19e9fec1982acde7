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
//! a re-exported solution shows on reload; `/favicon.ico` is 204 (no icon); anything else is
//! 404.
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
    /// 204: `/favicon.ico`, which browsers ask for unprompted; answered with nothing rather
    /// than 404, so the browser's console shows no failed request.
    NoIcon,
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
    if path == "/favicon.ico" {
        return Answer::NoIcon;
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
            Answer::NoIcon => tiny_http::Response::empty(204).boxed(),
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
#[path = "viewer_tests.rs"]
mod tests;
