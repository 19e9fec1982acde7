//! Plan maps of per-sensor values as inline SVG for `report.html`: the sensor points of one
//! grid seen from above (scene frame, x east, y north, metres), each a square coloured by
//! the class its value falls in, the room outline, a legend with its scale and unit, a
//! north arrow and a scale bar.
//!
//! **Room outline.** The horizontal model triangles (|n_z| ≥ 0.99, back faces excluded)
//! that lie at or below the grid's lowest sensor, at the highest such level (within
//! [`LEVEL_TOLERANCE_M`]): the floor just below the work plane. When the grid's room is
//! known (HBJSON: `imported.group_room`), only that room's faces count. Otherwise (OBJ
//! and `.rad` scenes) a triangle must overlap the sensors' footprint and lie within it
//! grown by [`FOOTPRINT_MARGIN`] of its size (at least 1 m), which keeps ground planes and
//! site slabs out. The outline drawn is the floor's boundary: the triangle edges that only
//! one floor triangle has.
//!
//! **Points.** Squares of 0.9 × the median nearest-neighbour spacing (at least 2 px), so a
//! regular grid reads as a tiled heat map whatever its sensor count (tested 10 … 10 000).

use crate::scene::Scene;
use glam::DVec2;
use std::collections::HashMap;
use std::fmt::Write;

/// Floor faces within this height of the highest floor level below the sensors belong to
/// the outline, m.
pub const LEVEL_TOLERANCE_M: f64 = 0.05;
/// Without a room, floor faces must lie within the sensors' footprint grown by this share
/// of its larger side (and by at least 1 m) on every side.
pub const FOOTPRINT_MARGIN: f64 = 0.25;
/// Largest side of a map's drawing area up to [`MAP_PX_SENSORS`] sensors, px.
pub const MAP_PX: f64 = 300.0;
/// Above this many sensors a map grows with √n, up to twice [`MAP_PX`], so that a point
/// stays ≥ 2 px wide (10 000 sensors on a square grid: 600 px, 5.4 px points).
pub const MAP_PX_SENSORS: usize = 2500;

/// Largest side of the drawing area of a map of `n` points, px.
pub fn map_px(n: usize) -> f64 {
    (MAP_PX * (n as f64 / MAP_PX_SENSORS as f64).sqrt()).clamp(MAP_PX, 2.0 * MAP_PX)
}
/// Colour of a floor face's fill.
const FLOOR_FILL: &str = "#ececec";
/// Colour of the outline.
const OUTLINE: &str = "#222222";

/// A triangle in plan, m.
pub type PlanTriangle = [DVec2; 3];

/// The floor triangles of a grid's room (module docs), in plan, m.
pub fn floor_triangles(scene: &Scene, sensors: &[usize], room: Option<&str>) -> Vec<PlanTriangle> {
    let Some((lo, hi, z_s)) = footprint(scene, sensors) else {
        return Vec::new();
    };
    let room_index = room.and_then(|r| scene.imported.rooms.iter().position(|x| x == r));
    let in_room = |group: u32| -> bool {
        match room_index {
            Some(ri) => scene
                .imported
                .group_room
                .get(group as usize)
                .copied()
                .flatten()
                .is_some_and(|r| r as usize == ri),
            None => true,
        }
    };
    let grow = (FOOTPRINT_MARGIN * (hi - lo).max_element()).max(1.0);
    let (glo, ghi) = (lo - DVec2::splat(grow), hi + DVec2::splat(grow));
    let candidates: Vec<(f64, PlanTriangle)> = scene.triangles[..scene.input_triangles]
        .iter()
        .filter(|t| t.normal().z.abs() >= 0.99 && in_room(t.group))
        .filter_map(|t| {
            let z = t.v.iter().map(|v| v.z).fold(f64::MIN, f64::max);
            if z > z_s + 1e-6 {
                return None;
            }
            let p = t.v.map(|v| v.truncate());
            let (tlo, thi) = bounds(&p);
            if room_index.is_none() {
                let overlaps = tlo.cmple(hi).all() && thi.cmpge(lo).all();
                let inside = tlo.cmpge(glo).all() && thi.cmple(ghi).all();
                if !(overlaps && inside) {
                    return None;
                }
            }
            Some((z, p))
        })
        .collect();
    let level = candidates.iter().map(|c| c.0).fold(f64::MIN, f64::max);
    candidates
        .into_iter()
        .filter(|c| c.0 >= level - LEVEL_TOLERANCE_M)
        .map(|c| c.1)
        .collect()
}

/// Plan bounds (min, max) of the sensors and the lowest sensor height, m.
fn footprint(scene: &Scene, sensors: &[usize]) -> Option<(DVec2, DVec2, f64)> {
    let pts: Vec<DVec2> = sensors
        .iter()
        .map(|&k| scene.sensors[k].position.truncate())
        .collect();
    if pts.is_empty() {
        return None;
    }
    let (lo, hi) = bounds(&pts);
    let z = sensors
        .iter()
        .map(|&k| scene.sensors[k].position.z)
        .fold(f64::MAX, f64::min);
    Some((lo, hi, z))
}

fn bounds(p: &[DVec2]) -> (DVec2, DVec2) {
    p.iter().fold(
        (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    )
}

/// An edge's ends in millimetres, the smaller first.
type EdgeKey = ((i64, i64), (i64, i64));

/// The edges only one of `tris` has (ends matched to the millimetre): the outline.
pub fn boundary_edges(tris: &[PlanTriangle]) -> Vec<[DVec2; 2]> {
    let key = |p: DVec2| ((p.x * 1000.0).round() as i64, (p.y * 1000.0).round() as i64);
    let mut count: HashMap<EdgeKey, (usize, [DVec2; 2])> = HashMap::new();
    let mut order = Vec::new();
    for t in tris {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            if ka == kb {
                continue;
            }
            let k = if ka < kb { (ka, kb) } else { (kb, ka) };
            let e = count.entry(k).or_insert_with(|| {
                order.push(k);
                (0, [a, b])
            });
            e.0 += 1;
        }
    }
    // In first-seen order, so the page is byte-deterministic.
    order
        .into_iter()
        .filter_map(|k| (count[&k].0 == 1).then_some(count[&k].1))
        .collect()
}

/// True when `p` lies in the triangle (edges included, to `tol` m).
pub fn in_triangle(p: DVec2, t: &PlanTriangle, tol: f64) -> bool {
    let side = |a: DVec2, b: DVec2| {
        let e = b - a;
        e.perp_dot(p - a) / e.length().max(1e-300)
    };
    let s = [side(t[0], t[1]), side(t[1], t[2]), side(t[2], t[0])];
    s.iter().all(|v| *v >= -tol) || s.iter().all(|v| *v <= tol)
}

/// A value scale of equal classes over `lo … hi`, coloured from a colour-blind-safe
/// gradient sampled at the classes' middles.
#[derive(Clone, Debug)]
pub struct Scale {
    /// Quantity shown (legend title).
    pub name: String,
    /// Unit (`%`, `h`).
    pub unit: String,
    /// Lower end of the first class, in the unit.
    pub lo: f64,
    /// Upper end of the last class (included in it), in the unit.
    pub hi: f64,
    /// Number of classes.
    pub classes: usize,
    /// The gradient.
    pub gradient: colorous::Gradient,
    /// A pass/fail threshold marked on the legend (in the unit), when inside the scale.
    pub threshold: Option<(f64, String)>,
}

impl Scale {
    /// Class of `v` (values outside the scale go to the end classes); `None` for NaN.
    pub fn class_of(&self, v: f64) -> Option<usize> {
        if v.is_nan() {
            return None;
        }
        let t = (v - self.lo) / (self.hi - self.lo) * self.classes as f64;
        Some((t.floor().max(0.0) as usize).min(self.classes - 1))
    }

    /// `#rrggbb` of class `i`.
    pub fn colour(&self, i: usize) -> String {
        let t = (i as f64 + 0.5) / self.classes as f64;
        format!("#{:x}", self.gradient.eval_continuous(t))
    }

    /// Lower bound of class `i`, in the unit.
    pub fn bound(&self, i: usize) -> f64 {
        self.lo + (self.hi - self.lo) * i as f64 / self.classes as f64
    }
}

/// The smallest of 1, 2, 2.5, 5 × 10^k that is ≥ `v` (and ≥ `floor`).
pub fn nice_ceil(v: f64, floor: f64) -> f64 {
    let v = v.max(floor);
    let k = v.log10().floor();
    let base = 10f64.powf(k);
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * base)
        .find(|x| *x >= v * (1.0 - 1e-12))
        .unwrap_or(10.0 * base)
}

/// Median distance from a point to its nearest neighbour, m (0 for fewer than 2 points).
fn spacing(pts: &[DVec2]) -> f64 {
    if pts.len() < 2 {
        return 0.0;
    }
    let tree = rstar::RTree::bulk_load(pts.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>());
    let mut d: Vec<f64> = pts
        .iter()
        .filter_map(|p| {
            tree.nearest_neighbor_iter(&[p.x, p.y])
                .map(|q| DVec2::new(q[0], q[1]).distance(*p))
                .find(|d| *d > 1e-9)
        })
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Number as written in the SVG: one decimal, no `-0.0`.
fn n1(v: f64) -> String {
    let s = format!("{v:.1}");
    if s == "-0.0" {
        "0.0".into()
    } else {
        s
    }
}

/// One map: the sensor points of `pts` (plan, m) coloured by `values` on `scale`, the
/// floor `tris` and its outline, the legend, north arrow and scale bar, as an `<svg>`
/// element. `labels` name the points in their tooltips (sensor indices).
pub fn map_svg(
    pts: &[DVec2],
    labels: &[usize],
    values: &[f64],
    scale: &Scale,
    tris: &[PlanTriangle],
) -> String {
    let mut all: Vec<DVec2> = pts.to_vec();
    all.extend(tris.iter().flatten());
    let d = spacing(pts);
    let (mut lo, mut hi) = if all.is_empty() {
        (DVec2::ZERO, DVec2::ONE)
    } else {
        bounds(&all)
    };
    let pad = DVec2::splat((0.5 * d).max(1e-3 * (hi - lo).max_element()).max(0.05));
    lo -= pad;
    hi += pad;
    let ext = (hi - lo).max(DVec2::splat(1e-6));
    let side_px = map_px(pts.len());
    let px = side_px / ext.max_element();
    let (w, h) = (ext.x * px, ext.y * px);
    let (m, top) = (10.0, 28.0);
    let legend_y = top + h + 34.0;
    let total_w = (w + 2.0 * m).max(330.0);
    let total_h = legend_y + 46.0;
    let x = |p: DVec2| m + (p.x - lo.x) * px;
    let y = |p: DVec2| top + (hi.y - p.y) * px;
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg class=\"map\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" role=\"img\" \
         aria-label=\"{} ({})\">",
        n1(total_w),
        n1(total_h),
        n1(total_w),
        n1(total_h),
        esc(&scale.name),
        esc(&scale.unit)
    );
    let _ = write!(
        s,
        "<text x=\"{m}\" y=\"16\" class=\"t\">{} ({})</text>",
        esc(&scale.name),
        esc(&scale.unit)
    );
    let _ = write!(
        s,
        "<g class=\"plan\"><rect class=\"frame\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" \
         fill=\"#ffffff\"/>",
        n1(m),
        n1(top),
        n1(w),
        n1(h)
    );
    for t in tris {
        let _ = write!(
            s,
            "<polygon points=\"{},{} {},{} {},{}\" fill=\"{FLOOR_FILL}\" stroke=\"{FLOOR_FILL}\" \
             stroke-width=\"0.5\"/>",
            n1(x(t[0])),
            n1(y(t[0])),
            n1(x(t[1])),
            n1(y(t[1])),
            n1(x(t[2])),
            n1(y(t[2]))
        );
    }
    let side = (0.9 * d * px).max(2.0);
    for ((p, k), v) in pts.iter().zip(labels).zip(values) {
        let fill = scale
            .class_of(*v)
            .map_or_else(|| "#999999".to_string(), |c| scale.colour(c));
        let _ = write!(
            s,
            "<rect class=\"pt\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{fill}\">\
             <title>s{k}: {v:.1} {}</title></rect>",
            n1(x(*p) - side / 2.0),
            n1(y(*p) - side / 2.0),
            n1(side),
            n1(side),
            esc(&scale.unit)
        );
    }
    let mut outline = String::new();
    for e in boundary_edges(tris) {
        let _ = write!(
            outline,
            "M{},{}L{},{}",
            n1(x(e[0])),
            n1(y(e[0])),
            n1(x(e[1])),
            n1(y(e[1]))
        );
    }
    if !outline.is_empty() {
        let _ = write!(
            s,
            "<path class=\"outline\" d=\"{outline}\" fill=\"none\" stroke=\"{OUTLINE}\" \
             stroke-width=\"1.5\"/>"
        );
    }
    s.push_str("</g>");
    north_and_scale(&mut s, total_w, top, h, px, side_px);
    legend(&mut s, scale, m, legend_y);
    s.push_str("</svg>");
    s
}

/// A north arrow (scene y is north) at the top right and a scale bar below the plan.
fn north_and_scale(s: &mut String, total_w: f64, top: f64, h: f64, px: f64, side_px: f64) {
    let ax = total_w - 16.0;
    let _ = write!(
        s,
        "<g class=\"north\"><path d=\"M{ax},4 l5,14 l-5,-4 l-5,4 z\" fill=\"{OUTLINE}\"/>\
         <text x=\"{}\" y=\"{}\" class=\"s\">N</text></g>",
        ax - 14.0,
        16
    );
    // A bar of 1, 2, 2.5 or 5 × 10^k m, about a quarter of the plan's width or less.
    let target = 0.25 * side_px / px;
    let len = nice_ceil(target, 1e-3);
    let len = if len * px > 0.4 * side_px {
        len / 2.0
    } else {
        len
    };
    let (x0, y0) = (10.0, top + h + 14.0);
    let _ = write!(
        s,
        "<g class=\"scalebar\"><path d=\"M{},{}h{}\" stroke=\"{OUTLINE}\" stroke-width=\"3\"/>\
         <text x=\"{}\" y=\"{}\" class=\"s\">{} m</text></g>",
        n1(x0),
        n1(y0),
        n1(len * px),
        n1(x0 + len * px + 6.0),
        n1(y0 + 4.0),
        trim(len)
    );
}

/// The legend: one swatch per class with the class bounds below, and the threshold.
fn legend(s: &mut String, scale: &Scale, x0: f64, y0: f64) {
    let sw = 28.0;
    s.push_str("<g class=\"legend\">");
    for i in 0..scale.classes {
        let _ = write!(
            s,
            "<rect class=\"swatch\" data-class=\"{i}\" x=\"{}\" y=\"{}\" width=\"{sw}\" \
             height=\"14\" fill=\"{}\"/>",
            n1(x0 + sw * i as f64),
            n1(y0),
            scale.colour(i)
        );
    }
    for i in (0..=scale.classes).step_by(2) {
        let _ = write!(
            s,
            "<text x=\"{}\" y=\"{}\" class=\"s\" text-anchor=\"middle\">{}</text>",
            n1(x0 + sw * i as f64),
            n1(y0 + 27.0),
            trim(scale.bound(i))
        );
    }
    if let Some((v, label)) = &scale.threshold {
        if *v >= scale.lo && *v <= scale.hi {
            let tx = x0 + sw * scale.classes as f64 * (v - scale.lo) / (scale.hi - scale.lo);
            let _ = write!(
                s,
                "<path d=\"M{},{}v20\" stroke=\"{OUTLINE}\" stroke-width=\"2\"/>\
                 <text x=\"{}\" y=\"{}\" class=\"s\" text-anchor=\"middle\">{}</text>",
                n1(tx),
                n1(y0 - 3.0),
                n1(tx),
                n1(y0 + 40.0),
                esc(label)
            );
        }
    }
    s.push_str("</g>");
}

/// A bound as written on a legend: no trailing zeros.
fn trim(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

pub use crate::files::html_escape as esc;
