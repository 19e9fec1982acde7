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

use crate::error::{Error, Result};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// The viewer page, embedded so the binary serves it without any installed files.
pub const VIEWER_HTML: &str = include_str!("../../assets/viewer.html");

/// A bound viewer server; [`ViewerServer::run`] answers requests.
pub struct ViewerServer {
    server: tiny_http::Server,
    glb: PathBuf,
    name: String,
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
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

fn header(name: &str, value: &str) -> tiny_http::Header {
    // Only fixed ASCII names and values reach here, which tiny_http always accepts.
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes())
        .unwrap_or_else(|()| unreachable!("ASCII header {name}"))
}

impl ViewerServer {
    /// Binds 127.0.0.1:`port` (0: any free port) to serve the viewer with `glb`.
    ///
    /// # Errors
    /// [`Error::Io`] when `glb` cannot be read; [`Error::Input`] when it is not a file or
    /// its name is not UTF-8, or when the port cannot be bound (in use, not permitted).
    pub fn bind(glb: &Path, port: u16) -> Result<ViewerServer> {
        let meta = std::fs::metadata(glb).map_err(|e| Error::io(glb, e))?;
        if !meta.is_file() {
            return Err(Error::input(glb, None, None, "not a file"));
        }
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
        Ok(ViewerServer {
            server,
            glb: glb.to_path_buf(),
            name,
        })
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

    /// The response to one request path (query included).
    fn respond(&self, url: &str) -> tiny_http::ResponseBox {
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        let no_store = header("Cache-Control", "no-store");
        if path == "/" && query.is_empty() {
            let to = format!("/?glb={}", percent_encode(&self.name));
            return tiny_http::Response::empty(302)
                .with_header(header("Location", &to))
                .boxed();
        }
        if matches!(path, "/" | "/index.html" | "/viewer.html") {
            return tiny_http::Response::from_string(VIEWER_HTML)
                .with_header(header("Content-Type", "text/html; charset=utf-8"))
                .with_header(no_store)
                .boxed();
        }
        if percent_decode(path.trim_start_matches('/')).as_deref() == Some(self.name.as_str()) {
            return match std::fs::read(&self.glb) {
                Ok(bytes) => tiny_http::Response::from_data(bytes)
                    .with_header(header("Content-Type", "model/gltf-binary"))
                    .with_header(no_store)
                    .boxed(),
                Err(e) => tiny_http::Response::from_string(format!("{}: {e}", self.glb.display()))
                    .with_status_code(500)
                    .boxed(),
            };
        }
        tiny_http::Response::from_string("not found")
            .with_status_code(404)
            .boxed()
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
            let response = self.respond(request.url());
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
    use std::io::{Read, Write};
    use std::net::TcpStream;

    /// A raw HTTP/1.0 GET: (status line, body bytes).
    fn get(addr: SocketAddr, path: &str) -> (String, Vec<u8>) {
        let mut s = TcpStream::connect(addr).unwrap();
        write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
        let mut raw = Vec::new();
        s.read_to_end(&mut raw).unwrap();
        let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        let head = String::from_utf8_lossy(&raw[..split]).into_owned();
        (head, raw[split + 4..].to_vec())
    }

    /// The status code of a response head (tiny_http answers in the request's version).
    fn status(head: &str) -> &str {
        head.split(' ').nth(1).unwrap_or("")
    }

    #[test]
    fn serves_the_page_and_the_glb_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let glb = dir.path().join("my room.glb");
        let bytes: Vec<u8> = (0..=255u8).cycle().take(5000).collect();
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
