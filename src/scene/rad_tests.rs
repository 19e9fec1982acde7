//! Unit tests of the Radiance scene reader: lexer, `!xform` arguments, polygons, materials,
//! aliases and errors, against hand-computed values.

use super::*;
use crate::photometry::Rgb;
use crate::scene::material::{
    glass_transmissivity_from_transmittance, glass_transmittance_from_transmissivity,
};
use crate::scene::rad_lexer::{lex, Item};
use crate::scene::rad_xform;
use glam::DVec3;

fn p() -> PathBuf {
    PathBuf::from("t.rad")
}

fn words(args: &str) -> Vec<String> {
    args.split_whitespace().map(str::to_string).collect()
}

fn area(t: &[Triangle]) -> f64 {
    t.iter().map(Triangle::area).sum()
}

fn normal(t: &Triangle) -> DVec3 {
    (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]).normalize()
}

fn near(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-12
}

/// The line and the shown message of the input error `text` gives, which must name `t.rad`.
fn err_of(text: &str) -> (usize, String) {
    let (shown, path, line, _) = crate::error::input_parts(parse(&p(), text).unwrap_err());
    assert_eq!(path, p());
    (line.expect("a line"), shown)
}

const GREY: &str = "void plastic grey 0 0 5 0.5 0.5 0.5 0 0\n";

#[test]
fn lexer_splits_words_strings_comments_and_continued_commands() {
    let text = "# a comment line\nvoid plastic \"my mat\" 0 0 5 .5 .5 .5 0 0 # trailing\n\
                !xform -t 1 0 0 \\\n   'a b.rad'\nnext 'x' # end";
    let items = lex(&p(), text).unwrap();
    let w: Vec<(&str, usize)> = items
        .iter()
        .filter_map(|i| match i {
            Item::Word(w, l) => Some((w.as_str(), *l)),
            Item::Command(..) => None,
        })
        .collect();
    assert_eq!(w.len(), 3 + 3 + 5 + 2);
    assert_eq!(w[2], ("my mat", 2));
    assert_eq!(w[10], ("0", 2));
    // The continued command counts its two lines: the next word is on line 5.
    assert_eq!(w[11], ("next", 5));
    assert_eq!(w[12], ("x", 5));
    let cmds: Vec<_> = items
        .iter()
        .filter_map(|i| match i {
            Item::Command(c, l) => Some((c.clone(), *l)),
            Item::Word(..) => None,
        })
        .collect();
    assert_eq!(
        cmds,
        [(words("xform -t 1 0 0 a"), 3)].map(|(mut c, l)| {
            c[5] = "a b.rad".into();
            (c, l)
        })
    );
}

#[test]
fn lexer_reads_windows_line_ends() {
    let items = lex(&p(), "!xform -t 1 0 0 \\\r\n a.rad\r\nx\r\n").unwrap();
    assert_eq!(items[0], Item::Command(words("xform -t 1 0 0 a.rad"), 1));
    assert_eq!(items[1], Item::Word("x".into(), 3));
}

#[test]
fn lexer_refuses_unterminated_strings_naming_the_line() {
    for text in ["void plastic \"open 0 0 5 1 1 1 0 0", "\n\n!xform 'a.rad"] {
        let (line, msg) = match lex(&p(), text).unwrap_err() {
            Error::Input { line, message, .. } => (line, message),
            e => panic!("{e}"),
        };
        assert_eq!(line, Some(if text.starts_with('\n') { 3 } else { 1 }));
        assert!(msg.contains("unterminated"), "{msg}");
    }
}

/// The single transform of an `!xform` line.
fn xf(args: &str) -> DAffine3 {
    let x = rad_xform::parse(&p(), 1, &words(&format!("{args} f.rad"))).unwrap();
    assert_eq!(x.copies.len(), 1, "{args}");
    x.copies[0]
}

#[test]
fn xform_transforms_compose_in_the_order_written() {
    let v = DVec3::new(1.0, 0.0, 0.0);
    // Translate to (2, 2, 3), then a quarter turn about z (counter-clockwise seen from +z).
    assert!(near(
        xf("-t 1 2 3 -rz 90").transform_point3(v),
        DVec3::new(-2.0, 2.0, 3.0)
    ));
    // The other order: (0, 1, 0), then moved.
    assert!(near(
        xf("-rz 90 -t 1 2 3").transform_point3(v),
        DVec3::new(1.0, 3.0, 3.0)
    ));
    assert!(near(xf("-rx 90").transform_point3(DVec3::Y), DVec3::Z));
    assert!(near(xf("-ry 90").transform_point3(DVec3::Z), DVec3::X));
    assert!(near(xf("-rz -90").transform_point3(DVec3::X), -DVec3::Y));
    assert!(near(
        xf("-s 2 -t 1 0 0").transform_point3(DVec3::ONE),
        DVec3::new(3.0, 2.0, 2.0)
    ));
    let q = DVec3::new(1.0, 2.0, 3.0);
    assert!(near(
        xf("-mx").transform_point3(q),
        DVec3::new(-1.0, 2.0, 3.0)
    ));
    assert!(near(
        xf("-my").transform_point3(q),
        DVec3::new(1.0, -2.0, 3.0)
    ));
    assert!(near(
        xf("-mz").transform_point3(q),
        DVec3::new(1.0, 2.0, -3.0)
    ));
    // -i 3: one copy, moved three times.
    assert!(near(
        xf("-i 3 -t 1 0 0").transform_point3(DVec3::ZERO),
        3.0 * DVec3::X
    ));
    let x = rad_xform::parse(&p(), 1, &words("-n a -m red -I -c f.rad g.rad")).unwrap();
    assert_eq!(x.name.as_deref(), Some("a"));
    assert_eq!(x.modifier.as_deref(), Some("red"));
    assert!(x.invert);
    assert_eq!(x.files, ["f.rad", "g.rad"]);
}

#[test]
fn xform_arrays_make_every_copy_once() {
    let x = rad_xform::parse(&p(), 1, &words("-a 3 -t 2 0 0 f.rad")).unwrap();
    let at: Vec<DVec3> = x
        .copies
        .iter()
        .map(|c| c.transform_point3(DVec3::ZERO))
        .collect();
    assert_eq!(at, [0.0, 2.0, 4.0].map(|x| DVec3::new(x, 0.0, 0.0)));
    // A 2 × 3 array after a first move: (1, 0, 1) turned 0 or 90° about z, raised 0, 10, 20.
    let x = rad_xform::parse(&p(), 1, &words("-t 0 0 1 -a 2 -rz 90 -a 3 -t 0 0 10 f.rad")).unwrap();
    assert_eq!(x.copies.len(), 6);
    for (a, b) in [(1.0, 0.0), (0.0, 1.0)] {
        for z in [1.0, 11.0, 21.0] {
            let want = DVec3::new(a, b, z);
            let n = x
                .copies
                .iter()
                .filter(|c| near(c.transform_point3(DVec3::X), want))
                .count();
            assert_eq!(n, 1, "{want}");
        }
    }
}

#[test]
fn xform_refuses_what_it_cannot_read() {
    for (args, word) in [
        ("-t 1 2", "needs more numbers"),
        ("-rz nan f.rad", "finite"),
        ("-a 0 f.rad", "whole number"),
        ("-a 1000 -a 1000 f.rad", "copies"),
        ("-s 0 f.rad", "zero"),
        ("-e f.rad", "not supported"),
        ("-t 1 0 0", "no file"),
    ] {
        let e = rad_xform::parse(&p(), 7, &words(args))
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.rad:7") && e.contains(word), "{args}: {e}");
    }
}

#[test]
fn seam_polygon_of_a_wall_with_two_windows_has_the_wall_less_the_windows() {
    // honeybee's Room_West_Back: a 6 × 3 m wall whose two 2.4 × 1.5 m windows are joined to
    // the outline by seams (envelope.rad), with the window polygons after it.
    let text = format!(
        "{GREY}void glass clear 0 0 3 0.96 0.96 0.96\n\
         grey polygon Room_West_Back 0 0 48 0.0 0.0 0.0 6.0 0.0 0.0 6.0 0.0 3.0 0.0 0.0 3.0 \
         0.3 0.0 2.3 2.7 0.0 2.3 2.7 0.0 0.8 3.3 0.0 0.8 3.3 0.0 2.3 5.7 0.0 2.3 5.7 0.0 0.8 \
         3.3 0.0 0.8 2.7 0.0 0.8 0.3 0.0 0.8 0.3 0.0 2.3 0.0 0.0 3.0\n\
         clear polygon Glz0 0 0 12 0.3 0.0 0.8 2.7 0.0 0.8 2.7 0.0 2.3 0.3 0.0 2.3\n\
         clear polygon Glz1 0 0 12 3.3 0.0 0.8 5.7 0.0 0.8 5.7 0.0 2.3 3.3 0.0 2.3\n"
    );
    let r = parse(&p(), &text).unwrap();
    let wall: Vec<Triangle> = r
        .triangles
        .iter()
        .filter(|t| t.group == 0)
        .copied()
        .collect();
    assert!(
        (area(&wall) - (18.0 - 2.0 * 2.4 * 1.5)).abs() < 1e-9,
        "{}",
        area(&wall)
    );
    assert!((area(&r.triangles) - 18.0).abs() < 1e-9);
    assert_eq!(r.groups, ["Room_West_Back", "Glz0", "Glz1"]);
    // Counter-clockwise seen from −y: the wall faces −y (outward, as honeybee writes it).
    assert!(r.triangles.iter().all(|t| near(normal(t), -DVec3::Y)));
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    // The glass is glazing, as an MTL material with Tf > 0 is.
    assert!(!r.materials[0].is_glazing() && r.materials[1].is_glazing());
}

#[test]
fn glass_transmissivity_and_transmittance_convert_both_ways() {
    // Radiance's own conversion (its reference manual, `glass`), written out.
    let radiance = |tn: f64| {
        ((0.8402528435 + 0.0072522239 * tn * tn).sqrt() - 0.9166530661) / 0.0036261119 / tn
    };
    for tn in [0.05, 0.3, 0.64, 0.88, 0.9] {
        let t = glass_transmissivity_from_transmittance(tn);
        assert!((t - radiance(tn)).abs() < 1e-6, "{tn}: {t}");
        let back = glass_transmittance_from_transmissivity(t);
        // The constants have ten digits; the inverse uses the Fresnel terms of n = 1.52.
        assert!((back - tn).abs() < 1e-7, "{tn}: {back}");
    }
    // The manual: transmittance 0.88 (clear glass) is transmissivity 0.96.
    assert!((glass_transmissivity_from_transmittance(0.88) - 0.96).abs() < 0.002);
    assert!((glass_transmittance_from_transmissivity(0.96) - 0.88).abs() < 0.002);
    // The reader gives glass its transmittance, channel by channel.
    let r = parse(
        &p(),
        "void glass g 0 0 3 0.96 0.5 0\ng polygon w 0 0 9 0 0 0 1 0 0 0 1 0\n",
    )
    .unwrap();
    let m = &r.materials[0];
    assert_eq!(m.tf.x, glass_transmittance_from_transmissivity(0.96));
    assert_eq!(m.tf.y, glass_transmittance_from_transmissivity(0.5));
    assert_eq!((m.tf.z, m.kd), (0.0, Rgb::ZERO));
}

#[test]
fn materials_convert_as_the_hbjson_reader_does() {
    let text = "void plastic p 0 0 5 0.4 0.5 0.6 0.05 0.1\n\
                void metal m 0 0 5 0.3 0.3 0.3 0 0\n\
                void glow e 0 0 4 10 20 30 0\n\
                void light l 0 0 3 1 2 3\n\
                void trans t 0 0 7 0.5 0.5 0.5 0 0 0 0\n";
    let mut text = text.to_string();
    for (i, m) in ["p", "m", "e", "l", "t"].iter().enumerate() {
        text += &format!("{m} polygon s{i} 0 0 9 0 0 {i} 1 0 {i} 0 1 {i}\n");
    }
    let r = parse(&p(), &text).unwrap();
    let names: Vec<&str> = r.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["p", "m", "e", "l", "t"]);
    // Plastic: c (1 − s) diffusely plus s specularly, all reflected diffusely.
    let kd = r.materials[0].kd;
    let want = [0.4, 0.5, 0.6].map(|c| c * 0.95 + 0.05);
    assert!((kd.x - want[0]).abs() < 1e-12 && (kd.z - want[2]).abs() < 1e-12);
    assert_eq!(r.materials[2].ke, Rgb::new(10.0, 20.0, 30.0));
    assert!(r.materials[3].is_emitter());
    assert!(!r.materials.iter().any(Material::is_glazing));
    // Approximations are warnings naming file and line.
    assert!(r
        .warnings
        .iter()
        .any(|w| w.starts_with("t.rad:1:") && w.contains("specularity")));
    assert!(r.warnings.iter().any(|w| w.starts_with("t.rad:5:")));
}

#[test]
fn aliases_and_inherit_resolve_to_their_material() {
    let dir = tempfile::tempdir().unwrap();
    let main = dir.path().join("main.rad");
    std::fs::write(
        dir.path().join("part.rad"),
        "inherit polygon a 0 0 9 0 0 0 1 0 0 0 1 0\nred polygon b 0 0 9 0 0 1 1 0 1 0 1 1\n",
    )
    .unwrap();
    let text = "void plastic red 0 0 5 0.5 0 0 0 0\nvoid alias red2 red\n\
                void alias red3 red2\nvoid plastic blue 0 0 5 0 0 0.5 0 0\n\
                red3 polygon p 0 0 9 0 0 0 1 0 0 0 1 0\n\
                !xform -m blue part.rad\n";
    let r = parse(&main, text).unwrap();
    let names: Vec<&str> = r.materials.iter().map(|m| m.name.as_str()).collect();
    // red3 is red under a new name; -m gives blue to `inherit` and to `red` surfaces alike.
    assert_eq!(names, ["red3", "blue"]);
    assert_eq!(r.materials[0].kd, Rgb::new(0.5, 0.0, 0.0));
    assert_eq!(r.triangles.len(), 3);
    assert!(r.triangles[1..].iter().all(|t| t.material == 1));

    let (line, msg) = err_of("inherit polygon a 0 0 9 0 0 0 1 0 0 0 1 0\n");
    assert!(line == 1 && msg.contains("inherit"), "{msg}");
    let (line, msg) = err_of(&format!("{GREY}void alias g2 nothere\n"));
    assert!(
        line == 2 && msg.contains("nothere") && msg.contains("before"),
        "{msg}"
    );
    let (line, msg) = err_of(&format!("{GREY}grey alias g2 grey\n"));
    assert!(line == 2 && msg.contains("void alias"), "{msg}");
    // An alias of void leaves its surfaces out, with a warning.
    let r = parse(
        &p(),
        "void alias nothing void\nnothing polygon a 0 0 9 0 0 0 1 0 0 0 1 0\n",
    )
    .unwrap();
    assert!(r.triangles.is_empty() && r.warnings[0].contains("void"));
}

#[test]
fn xform_places_copies_and_keeps_mirrored_surfaces_facing_out() {
    let dir = tempfile::tempdir().unwrap();
    // A unit square facing +z.
    std::fs::write(
        dir.path().join("sq.rad"),
        "grey polygon sq 0 0 12 0 0 0 1 0 0 1 1 0 0 1 0\n",
    )
    .unwrap();
    let main = dir.path().join("main.rad");
    let text = format!("{GREY}!xform -n row -a 4 -t 2 0 0 sq.rad\n!xform -mz -t 0 0 5 sq.rad\n");
    let r = parse(&main, &text).unwrap();
    assert_eq!(r.triangles.len(), 5 * 2);
    assert!((area(&r.triangles) - 5.0).abs() < 1e-12);
    assert_eq!(r.groups, ["row.sq", "sq"]);
    let xs: f64 = r.triangles[..8].iter().map(|t| t.centroid().x).sum::<f64>() / 8.0;
    assert!((xs - (0.5 + 3.0)).abs() < 1e-12, "{xs}");
    assert!(r.triangles[..8].iter().all(|t| near(normal(t), DVec3::Z)));
    // The mirror image of a surface facing up, mirrored in z, faces down: xform reverses the
    // vertex order (a mirrored closed box still faces out), here at z = 5.
    assert!(r.triangles[8..].iter().all(|t| near(normal(t), -DVec3::Z)));
    assert!(r.triangles[8..]
        .iter()
        .all(|t| t.v.iter().all(|v| v.z == 5.0)));
    // -I turns it.
    let r = parse(&main, &format!("{GREY}!xform -I sq.rad\n")).unwrap();
    assert!(r.triangles.iter().all(|t| near(normal(t), -DVec3::Z)));
}

#[test]
fn errors_name_the_line_and_the_word() {
    let poly = "grey polygon a 0 0 9 0 0 0 1 0 0 0 1 0\n";
    for (text, line, word) in [
        (
            format!("{GREY}grey sphere ball 0 0 4 0 0 0 1\n"),
            2,
            "sphere",
        ),
        (
            format!("{GREY}\ngrey polygon a 0 0 8 0 0 0 1 0 0 0 1\n"),
            3,
            "3n reals",
        ),
        (
            format!("{GREY}grey polygon a 0 0 9 0 0 0 1 0 nan 0 1 0\n"),
            2,
            "finite",
        ),
        (
            format!("{GREY}grey polygon a 0 0 9 0 0 0 1 0 1e999 0 1 0\n"),
            2,
            "finite",
        ),
        (
            format!("{GREY}grey polygon a 0 0 99 0 0 0\n"),
            2,
            "number of real",
        ),
        (
            format!("{GREY}grey polygon a 0 x 9\n"),
            2,
            "number of integer",
        ),
        (format!("{GREY}grey polygon a 0 0\n"), 2, "incomplete"),
        ("void plastic p 0 0 4 0.5 0.5 0.5 0\n".into(), 1, "5 reals"),
        (
            "void plastic p 0 0 5 1.5 0.5 0.5 0 0\n".into(),
            1,
            "reflectance",
        ),
        (
            "void plastic p 0 0 5 0.5 0.5 0.5 0.5 0\n".into(),
            1,
            "specularity",
        ),
        ("void mirror m 0 0 3 1 1 1\n".into(), 1, "mirror"),
        (
            "void trans t 0 0 7 0.5 0.5 0.5 0 0 0.3 0\n".into(),
            1,
            "transmitted",
        ),
        (
            "wood plastic p 0 0 5 0.5 0.5 0.5 0 0\n".into(),
            1,
            "modified",
        ),
        (
            format!("{GREY}void brightfunc f 2 a b 0 0\n"),
            2,
            "brightfunc",
        ),
        (poly.into(), 1, "before it is defined"),
        (
            format!("{GREY}!gensky 3 21 12\n"),
            2,
            "daystep makes its own sky",
        ),
        (
            format!("{GREY}!cat a.rad | grep x\n"),
            2,
            "no shell command",
        ),
        (
            format!("{GREY}!xform -t 1 0 0 a.rad ; rm x\n"),
            2,
            "no shell command",
        ),
        (format!("{GREY}!xform a.rad\n"), 2, "not found"),
    ] {
        let (l, msg) = err_of(&text);
        assert_eq!(l, line, "{text}: {msg}");
        assert!(msg.contains(word), "{text}: {msg}");
    }
    // A source is left out with a warning.
    let r = parse(
        &p(),
        "void light sun 0 0 3 1 1 1\nsun source s 0 0 4 0 0 1 0.5\n",
    )
    .unwrap();
    assert!(r.triangles.is_empty() && r.warnings[0].contains("source"));
}

#[test]
fn a_file_including_itself_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.rad");
    std::fs::write(&a, "!xform -t 1 0 0 b.rad\n").unwrap();
    std::fs::write(dir.path().join("b.rad"), "\n!xform -a 3 -t 0 0 1 a.rad\n").unwrap();
    let e = load(&[a]).unwrap_err();
    let s = e.to_string();
    assert!(s.contains("b.rad:2") && s.contains("recursive"), "{s}");
    assert_eq!(e.exit_code(), 1);
}
