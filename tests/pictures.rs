//! Pictures cannot exhaust memory (issue 22): the binary, under a 4 GB address-space limit,
//! refuses HDR image skies whose headers declare more pixels than daystep reads, more than
//! the file holds, or more than the machine can allocate — exit 1, naming the file — in
//! `instant` and `render --time`, instead of aborting on a failed allocation (exit 134).
//!
//! The pictures are written byte by byte here, from the formats' documentation (Radiance's
//! RGBE header and old-style runs; OpenEXR's magic, version, attributes and offset table),
//! not by daystep's writers. Property tests of the two readers (arbitrary and mutated
//! bytes, allocation measured) are in `parsers.rs`, next to the other parsers', and use
//! [`exr_header`].

use crate::util::stderr;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

/// The address-space limit of every run, KiB (`ulimit -v`): the pictures below would need
/// from 8.9 GB to 100 GB.
const ULIMIT_KIB: &str = "4000000";

/// A one-square scene with one sensor, so that anything but reading the sky is cheap.
fn tiny_scene(dir: &Path) -> PathBuf {
    std::fs::write(
        dir.join("scene.toml"),
        "geometry = \"m.obj\"\nsensors = \"s.pts\"\nup = \"z\"\n\
         [site]\nlatitude = 40\nlongitude = 0\nutc_offset_h = 0\n",
    )
    .unwrap();
    std::fs::write(dir.join("m.mtl"), "newmtl grey\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        dir.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl grey\nf 1 2 3 4\n",
    )
    .unwrap();
    std::fs::write(dir.join("s.pts"), "0.5 0.5 0.1 0 0 1\n").unwrap();
    dir.join("scene.toml")
}

/// Runs the binary with `args` under `ulimit -v` [`ULIMIT_KIB`], in a fresh working folder.
fn limited(args: &[&str]) -> (Output, Duration) {
    let cwd = tempfile::tempdir().unwrap();
    let start = Instant::now();
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {ULIMIT_KIB}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_daystep"))
        .args(args)
        .current_dir(cwd.path())
        .output()
        .expect("sh runs the binary");
    (o, start.elapsed())
}

/// Runs `instant` and `render --time` with `--sky image --image picture` on a tiny scene
/// and asserts each exits 1 with a message naming the picture and holding every one of
/// `words`.
fn refused_by_both_commands(picture: &Path, words: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let (scene, picture) = (scene.to_str().unwrap(), picture.to_str().unwrap());
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let common = [
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "image",
        "--image",
        picture,
        "--quality",
        "draft",
        "--no-cache",
        "--out",
        out,
    ];
    let instant: Vec<&str> = ["instant", scene].into_iter().chain(common).collect();
    let render: Vec<&str> = [
        "render",
        scene,
        "--view",
        "-vtv -vp 0.5 -1 0.5 -vd 0 1 -0.3",
    ]
    .into_iter()
    .chain(["-x", "16", "-y", "16"])
    .chain(common)
    .collect();
    for args in [instant, render] {
        let (o, took) = limited(&args);
        let e = stderr(&o);
        eprintln!("{} ({took:.2?}): {}", args[0], e.trim());
        assert_eq!(o.status.code(), Some(1), "{}: {e}", args[0]);
        assert!(e.contains(picture), "{}: not naming the file: {e}", args[0]);
        for w in words {
            assert!(e.contains(w), "{}: no {w:?} in {e}", args[0]);
        }
    }
}

/// A Radiance picture's header: magic, format, empty line, resolution line.
fn hdr_header(res: &str) -> Vec<u8> {
    format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes()
}

fn exr_attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    for s in [name, kind] {
        out.extend_from_slice(s.as_bytes());
        out.push(0);
    }
    out.extend_from_slice(&(value.len() as i32).to_le_bytes());
    out.extend_from_slice(value);
}

/// A single-part scan-line OpenEXR header of `w × h` pixels with f32 channels `channels`
/// (in the sorted order the format asks for) and `compression` (0 none, 3 ZIP), as the
/// OpenEXR file layout describes it: magic 76 2f 31 01, version 2 with no flags, the
/// required attributes, a null byte. The offset table is the caller's.
pub(crate) fn exr_header(w: i32, h: i32, compression: u8, channels: &[&str]) -> Vec<u8> {
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut list = Vec::new();
    for c in channels {
        list.extend_from_slice(c.as_bytes());
        list.push(0);
        // FLOAT samples, linear flag and 3 reserved bytes, x and y sampling 1.
        for v in [2i32, 0, 1, 1] {
            list.extend_from_slice(&v.to_le_bytes());
        }
    }
    list.push(0);
    exr_attribute(&mut out, "channels", "chlist", &list);
    exr_attribute(&mut out, "compression", "compression", &[compression]);
    let window: Vec<u8> = [0, 0, w - 1, h - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    exr_attribute(&mut out, "dataWindow", "box2i", &window);
    exr_attribute(&mut out, "displayWindow", "box2i", &window);
    exr_attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    exr_attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    exr_attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    exr_attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    out.push(0);
    out
}

#[test]
fn a_64_byte_hdr_claiming_65536_squared_pixels_exits_1_instead_of_aborting() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = hdr_header("-Y 65536 +X 65536");
    b.resize(64, 2);
    let p = dir.path().join("huge.hdr");
    std::fs::write(&p, &b).unwrap();
    refused_by_both_commands(
        &p,
        &["65536 x 65536 pixels is more than daystep reads (2^28 pixels)"],
    );
}

#[test]
fn a_small_exr_claiming_100000_squared_pixels_exits_1_instead_of_aborting() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = exr_header(100_000, 100_000, 0, &["B", "G", "R"]);
    // A short offset table: four of the 100 000 entries (one scan line a block).
    let end = (b.len() + 32) as u64;
    for _ in 0..4 {
        b.extend_from_slice(&end.to_le_bytes());
    }
    assert!(b.len() < 400, "{}", b.len());
    let p = dir.path().join("huge.exr");
    std::fs::write(&p, &b).unwrap();
    refused_by_both_commands(
        &p,
        &["100000 x 100000 pixels is more than daystep reads (2^28 pixels)"],
    );
}

#[test]
fn a_valid_hdr_too_large_for_memory_exits_1_instead_of_aborting() {
    // 16 384 × 16 384 (the pixel limit) in 196 KiB: each scanline is its first pixel and
    // two old-style repeat records (255, then 63 × 256). The file holds every pixel it
    // declares; the 8.9 GB image does not fit in 4 GB of address space.
    let dir = tempfile::tempdir().unwrap();
    let mut b = hdr_header("-Y 16384 +X 16384");
    for _ in 0..16384 {
        b.extend_from_slice(&[128, 128, 128, 129, 1, 1, 1, 255, 1, 1, 1, 63]);
    }
    let p = dir.path().join("valid.hdr");
    std::fs::write(&p, &b).unwrap();
    refused_by_both_commands(&p, &["16384 x 16384", "not enough memory"]);
}

#[test]
fn an_exr_within_the_limit_but_too_large_for_memory_exits_1_instead_of_aborting() {
    // 16 384 × 16 384 ZIP-compressed, four f32 channels: the decoder would hold 4 GiB of
    // samples and the image 8.9 GB. Every chunk of the offset table is in the file (a few
    // bytes each), so only the memory stops it.
    let dir = tempfile::tempdir().unwrap();
    let mut b = exr_header(16384, 16384, 3, &["B", "G", "R", "err"]);
    let chunks = 16384 / 16;
    let first = b.len() + 8 * chunks;
    let chunk = 8 + 4;
    for k in 0..chunks {
        b.extend_from_slice(&((first + k * chunk) as u64).to_le_bytes());
    }
    for k in 0..chunks {
        b.extend_from_slice(&(16 * k as i32).to_le_bytes());
        b.extend_from_slice(&4i32.to_le_bytes());
        b.extend_from_slice(&[0; 4]);
    }
    let p = dir.path().join("valid.exr");
    std::fs::write(&p, &b).unwrap();
    refused_by_both_commands(&p, &["16384 x 16384", "not enough memory"]);
}

#[test]
fn a_picture_that_reads_but_cannot_be_indexed_as_a_sky_exits_1_instead_of_aborting() {
    // 4 096 × 4 096 reads in about 0.6 GB, but the sky's sub-sample index (9 sub-samples
    // of 48 bytes a pixel while it is built) needs about 7 GB: more than `ulimit -v`
    // leaves. Before the index was reserved fallibly, this aborted after the read.
    let dir = tempfile::tempdir().unwrap();
    let mut b = hdr_header("-Y 4096 +X 4096");
    for _ in 0..4096 {
        // The first pixel and old-style repeats of 255 and 15 × 256 of it.
        b.extend_from_slice(&[128, 128, 128, 129, 1, 1, 1, 255, 1, 1, 1, 15]);
    }
    let p = dir.path().join("sky4k.hdr");
    std::fs::write(&p, &b).unwrap();
    refused_by_both_commands(&p, &["4096 x 4096", "not enough memory to index"]);
}
