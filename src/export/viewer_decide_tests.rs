//! The viewer server's request decision ([`decide`]) under arbitrary input, against a
//! specification written apart from it; the server's own tests are the parent module.

use super::*;

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
