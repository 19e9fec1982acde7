//! Previews a person can play for a sequence of frames (one per time step): an animated
//! PNG, and a self-contained HTML page with a time slider and a play/pause button.
//!
//! Both are made from frames already tone-mapped or falsecoloured (8-bit sRGB RGBA, see
//! [`crate::render::tonemap`] and [`crate::render::falsecolor`]). The page embeds its PNG
//! frames as base64 data URIs and refers to nothing outside itself, so it opens offline
//! and can be mailed as one file.

use crate::error::{Error, Result};
use crate::files;
use crate::render::tonemap::dims;
use base64::Engine;
use std::path::Path;
use std::time::Duration;

/// How long each frame of the HTML page shows while playing.
pub const HTML_FRAME_MS: u32 = 500;

// APNG stores a frame's delay as a u16 fraction of a second: milliseconds while they fit,
// whole seconds (at most 65535) beyond.
fn delay_fraction(delay: Duration) -> (u16, u16) {
    let ms = delay.as_millis();
    match u16::try_from(ms) {
        Ok(ms) => (ms, 1000),
        Err(_) => (u16::try_from(delay.as_secs()).unwrap_or(u16::MAX), 1),
    }
}

/// Encodes `frames` (each 8-bit RGBA, row-major from the top-left, `width × height × 4`
/// bytes) as an animated PNG that loops forever, every frame shown for `delay` (kept to
/// the millisecond up to 65.535 s, to the second beyond). Viewers without APNG support
/// show the first frame.
///
/// # Errors
/// [`Error::Internal`] when there is no frame, a frame has the wrong size, or the encoder
/// fails.
pub fn encode_apng(
    width: usize,
    height: usize,
    frames: &[Vec<u8>],
    delay: Duration,
) -> Result<Vec<u8>> {
    let fail = |e: png::EncodingError| Error::Internal(format!("APNG encoding failed: {e}"));
    let (w, h) = dims(width, height)?;
    let count = u32::try_from(frames.len())
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| Error::Internal(format!("an APNG of {} frames", frames.len())))?;
    if let Some((i, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.len() != width * height * 4)
    {
        return Err(Error::Internal(format!(
            "APNG frame {i} has {} bytes, not {width}×{height}×4",
            f.len()
        )));
    }
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, w, h);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    encoder.set_animated(count, 0).map_err(fail)?;
    let (num, den) = delay_fraction(delay);
    encoder.set_frame_delay(num, den).map_err(fail)?;
    // Frames are whole and opaque: each replaces the last.
    encoder.set_blend_op(png::BlendOp::Source).map_err(fail)?;
    encoder.set_dispose_op(png::DisposeOp::None).map_err(fail)?;
    let mut writer = encoder.write_header().map_err(fail)?;
    for f in frames {
        writer.write_image_data(f).map_err(fail)?;
    }
    writer.finish().map_err(fail)?;
    Ok(bytes)
}

/// Writes [`encode_apng`]'s animated PNG to `path`, atomically.
///
/// # Errors
/// [`Error::Io`] naming `path` when it cannot be written; errors of [`encode_apng`].
pub fn write_apng(
    path: &Path,
    width: usize,
    height: usize,
    frames: &[Vec<u8>],
    delay: Duration,
) -> Result<()> {
    files::write_atomic(path, &encode_apng(width, height, frames, delay)?)
}

use crate::files::html_escape as escape;

// The page's behaviour; it names no resource, so the page needs nothing but itself.
const SCRIPT: &str = r#"
const frames = Array.from(document.querySelectorAll('#frames img'));
const slider = document.getElementById('t');
const label = document.getElementById('label');
const play = document.getElementById('play');
let timer = null;
function show(i) {
  frames.forEach((f, j) => { f.hidden = j !== i; });
  slider.value = i;
  label.textContent = frames[i].dataset.label;
}
slider.addEventListener('input', () => show(Number(slider.value)));
play.addEventListener('click', () => {
  if (timer === null) {
    timer = setInterval(() => show((Number(slider.value) + 1) % frames.length), FRAME_MS);
    play.textContent = 'Pause';
  } else {
    clearInterval(timer);
    timer = null;
    play.textContent = 'Play';
  }
});
show(0);
"#;

/// The HTML page of `frames` — (label, PNG bytes) in time order, the label the frame's
/// local time — titled `title`: the frames embedded as base64 `data:` URIs, a range slider
/// that picks the frame and shows its label, and a play/pause button that steps through
/// the frames every [`HTML_FRAME_MS`] ms, looping. Labels and title are HTML-escaped. The
/// page loads nothing from outside itself.
pub fn html_page(frames: &[(String, Vec<u8>)], title: &str) -> String {
    let engine = base64::engine::general_purpose::STANDARD;
    let title = escape(title);
    let first = frames.first().map(|(l, _)| escape(l)).unwrap_or_default();
    let mut imgs = String::new();
    for (i, (l, png)) in frames.iter().enumerate() {
        let l = escape(l);
        let hidden = if i == 0 { "" } else { " hidden" };
        imgs.push_str(&format!(
            "<img src=\"data:image/png;base64,{}\" alt=\"{l}\" data-label=\"{l}\"{hidden}>\n",
            engine.encode(png)
        ));
    }
    let max = frames.len().saturating_sub(1);
    let script = SCRIPT.replace("FRAME_MS", &HTML_FRAME_MS.to_string());
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>{title}</title>\n<style>\n\
         body {{ font-family: sans-serif; background: #1e1e1e; color: #eee; margin: 1em; }}\n\
         #frames img {{ max-width: 100%; image-rendering: pixelated; }}\n\
         #controls {{ display: flex; gap: 1em; align-items: center; margin: 0.5em 0; }}\n\
         #t {{ flex: 1; }}\n\
         </style>\n</head>\n<body>\n<h1>{title}</h1>\n\
         <div id=\"controls\"><button id=\"play\" type=\"button\">Play</button>\n\
         <input id=\"t\" type=\"range\" min=\"0\" max=\"{max}\" step=\"1\" value=\"0\" \
         aria-label=\"time\">\n<output id=\"label\">{first}</output></div>\n\
         <div id=\"frames\">\n{imgs}</div>\n<script>{script}</script>\n</body>\n</html>\n"
    )
}

/// Writes [`html_page`] to `path`, atomically.
///
/// # Errors
/// [`Error::Io`] naming `path` when it cannot be written; [`Error::Internal`] when there
/// is no frame.
pub fn write_html(path: &Path, frames: &[(String, Vec<u8>)], title: &str) -> Result<()> {
    if frames.is_empty() {
        return Err(Error::Internal("an HTML preview of no frames".into()));
    }
    files::write_atomic(path, html_page(frames, title).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::tonemap::encode_png;

    fn frame(width: usize, height: usize, shade: u8) -> Vec<u8> {
        (0..width * height)
            .flat_map(|i| [shade, (i % 256) as u8, 255 - shade, 255])
            .collect()
    }

    #[test]
    fn the_apng_decodes_as_every_frame_at_its_size() {
        let (w, h) = (12, 7);
        let frames: Vec<Vec<u8>> = (0..5).map(|k| frame(w, h, 40 * k)).collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.png");
        write_apng(&path, w, h, &frames, Duration::from_millis(250)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .unwrap();
        let actl = reader.info().animation_control().copied().unwrap();
        assert_eq!((actl.num_frames, actl.num_plays), (5, 0));
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        for (k, expected) in frames.iter().enumerate() {
            let info = reader.next_frame(&mut buf).unwrap();
            assert_eq!((info.width, info.height), (w as u32, h as u32), "frame {k}");
            let fctl = reader.info().frame_control().copied().unwrap();
            assert_eq!((fctl.delay_num, fctl.delay_den), (250, 1000));
            assert_eq!(&buf[..info.buffer_size()], &expected[..], "frame {k}");
        }
        assert!(reader.next_frame(&mut buf).is_err());
    }

    #[test]
    fn an_apng_refuses_a_frame_of_the_wrong_size() {
        let frames = vec![frame(4, 4, 0), frame(4, 3, 0)];
        assert!(encode_apng(4, 4, &frames, Duration::from_millis(100)).is_err());
        assert!(encode_apng(4, 4, &[], Duration::from_millis(100)).is_err());
    }

    #[test]
    fn long_delays_fall_back_to_seconds() {
        assert_eq!(
            delay_fraction(Duration::from_millis(65_535)),
            (65_535, 1000)
        );
        assert_eq!(delay_fraction(Duration::from_secs(90)), (90, 1));
    }

    #[test]
    fn the_page_embeds_every_frame_with_its_label_and_nothing_from_outside() {
        let labels = ["08:00", "09:00", "10:00 <DST>"];
        let frames: Vec<(String, Vec<u8>)> = labels
            .iter()
            .enumerate()
            .map(|(k, l)| {
                let png = encode_png(3, 2, &frame(3, 2, 90 * k as u8), &[]).unwrap();
                (l.to_string(), png)
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.html");
        write_html(&path, &frames, "Office & atrium, 21 June").unwrap();
        let page = std::fs::read_to_string(&path).unwrap();
        let prefix = "data:image/png;base64,";
        let embedded: Vec<Vec<u8>> = page
            .match_indices(prefix)
            .map(|(at, _)| {
                let rest = &page[at + prefix.len()..];
                let end = rest.find('"').unwrap();
                base64::engine::general_purpose::STANDARD
                    .decode(&rest[..end])
                    .unwrap()
            })
            .collect();
        assert_eq!(embedded.len(), 3);
        for ((_, png), back) in frames.iter().zip(&embedded) {
            assert_eq!(png, back);
        }
        assert_eq!(page.matches("<img ").count(), 3);
        for l in ["08:00", "09:00", "10:00 &lt;DST&gt;"] {
            assert!(page.contains(&format!("data-label=\"{l}\"")), "{l}");
        }
        assert!(page.contains("<title>Office &amp; atrium, 21 June</title>"));
        assert!(page.contains("type=\"range\"") && page.contains("max=\"2\""));
        assert!(page.contains("id=\"play\""));
        assert!(!page.to_lowercase().contains("http"));
        assert!(!page.contains("src=\"/") && !page.contains("url("));
        assert!(write_html(&path, &[], "none").is_err());
    }
}
