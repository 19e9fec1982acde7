//! `daystep view` end to end (issue 22): a file that is not a glTF binary is refused at
//! start with exit 1, and the running server answers its own origin only. The request rules
//! in detail (property tests included) are `export::viewer`'s unit tests; the page under its
//! Content-Security-Policy in a real browser is `tests/browser/run.sh`.

use crate::util::office;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A `daystep view` process, killed when dropped (a test that fails mid-way leaves no
/// server behind).
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `daystep view FILE --port 0` in a temporary working folder.
fn view(file: &std::path::Path, cwd: &std::path::Path) -> Server {
    Server(
        Command::new(env!("CARGO_BIN_EXE_daystep"))
            .arg("view")
            .arg(file)
            .args(["--port", "0"])
            .current_dir(cwd)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the binary runs"),
    )
}

/// A minimal glTF 2.0 binary: the header and one JSON chunk holding only `asset`.
fn minimal_glb() -> Vec<u8> {
    let json = br#"{"asset":{"version":"2.0"}} "#; // padded to a multiple of 4 bytes
    assert_eq!(json.len() % 4, 0);
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(20 + json.len() as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out
}

#[test]
fn view_refuses_a_scene_toml_at_start_with_exit_1() {
    let cwd = tempfile::tempdir().unwrap();
    let scene = office();
    let mut server = view(&scene, cwd.path());
    // Before the fix the server started and served the file; give it ample time to fail.
    let start = Instant::now();
    let status = loop {
        if let Some(s) = server.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "daystep view is serving {} instead of refusing it",
            scene.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    server
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains(&scene.display().to_string()), "{err}");
    assert!(err.contains("not a glTF binary"), "{err}");
}

#[test]
fn view_refuses_a_foreign_host_and_serves_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("room.glb");
    let bytes = minimal_glb();
    std::fs::write(&glb, &bytes).unwrap();
    let mut server = view(&glb, dir.path());
    let mut url = String::new();
    BufReader::new(server.0.stdout.take().unwrap())
        .read_line(&mut url)
        .unwrap();
    let origin = url
        .trim()
        .strip_prefix("http://")
        .and_then(|u| u.strip_suffix("/?glb=room.glb"))
        .unwrap_or_else(|| panic!("printed URL {url:?}"));
    let port = origin.strip_prefix("127.0.0.1:").unwrap();
    let get = |host: &str| {
        let mut s = TcpStream::connect(origin).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        write!(s, "GET /room.glb HTTP/1.0\r\nHost: {host}\r\n\r\n").unwrap();
        let mut raw = Vec::new();
        s.read_to_end(&mut raw).unwrap();
        let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        let head = String::from_utf8_lossy(&raw[..split]).into_owned();
        (head, raw[split + 4..].to_vec())
    };
    let (head, body) = get(&format!("attacker.example:{port}"));
    assert!(head.starts_with("HTTP/1.0 403"), "{head}");
    assert!(
        !body.starts_with(b"glTF"),
        "the model went to a foreign host"
    );
    let (head, body) = get(origin);
    assert!(head.starts_with("HTTP/1.0 200"), "{head}");
    assert_eq!(body, bytes);
}
