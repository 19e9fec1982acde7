//! Shades, shade meshes, sensor grids, views and dynamic (aperture) groups of an HBJSON
//! model ([`super`]), and the summary of bad geometry at the end.

use super::*;

impl Builder {
    /// Records an object's dynamic group, if it has one.
    pub(super) fn dynamic_group(&mut self, id: &str, r: &RadPropsJ) {
        let Some(g) = &r.dynamic_group_identifier else {
            return;
        };
        let groups = &mut self.out.imported.aperture_groups;
        let k = *self.group_of.entry(g.clone()).or_insert_with(|| {
            groups.push(ApertureGroup {
                identifier: g.clone(),
                ..ApertureGroup::default()
            });
            groups.len() - 1
        });
        let group = &mut groups[k];
        group.members.push(id.to_string());
        if group.states.is_empty() {
            group.states = r
                .states
                .iter()
                .flatten()
                .map(|s| s.modifier.clone().unwrap_or_else(|| "default".into()))
                .collect();
        }
    }

    pub(super) fn shade_mesh(&mut self, v: Value, ctx: &dyn Fn() -> String) -> Result<()> {
        let s: ShadeMeshJ = self.parse(v, "ShadeMesh", ctx)?;
        let who: Who = (&s.identifier, "ShadeMesh");
        let own = s
            .properties
            .radiance
            .as_ref()
            .and_then(|r| r.modifier.clone());
        let fallback = if s.is_detached {
            self.mods.context()
        } else {
            self.mods.set_modifier(None, Slot::ShadeExterior)
        };
        let material = self.material(own.as_deref(), fallback, who)?;
        let vertices = self.ring(&s.geometry.vertices, who)?;
        let group = self.out.groups.len() as u32;
        let mut any = false;
        for (k, face) in s.geometry.faces.iter().enumerate() {
            if !(3..=4).contains(&face.len()) {
                return Err(self.bad(
                    who,
                    format!("mesh face {k} has {} vertices: 3 or 4 expected", face.len()),
                ));
            }
            let Some(ring) = face
                .iter()
                .map(|&i| vertices.get(i).copied())
                .collect::<Option<Vec<_>>>()
            else {
                return Err(self.bad(
                    who,
                    format!(
                        "mesh face {k} refers to a vertex beyond the {} given",
                        vertices.len()
                    ),
                ));
            };
            // Mesh faces are often slivers; they are not counted one by one.
            let t = triangulate(&ring, &[], 0.0);
            for v in t.triangles {
                any = true;
                self.out.triangles.push(Triangle { v, material, group });
            }
        }
        if any {
            self.out.groups.push(s.identifier.clone());
            self.group_room.push(None);
        }
        Ok(())
    }

    pub(super) fn grid(&mut self, v: Value, ctx: &dyn Fn() -> String) -> Result<()> {
        let g: SensorGridJ = self.parse(v, "SensorGrid", ctx)?;
        let who: Who = (&g.identifier, "SensorGrid");
        let index = self.out.imported.grids.len() as u32;
        for (k, s) in g.sensors.iter().enumerate() {
            let p = self.point(s.pos, who)?;
            let d = DVec3::from_array(s.dir);
            if !d.is_finite() || d.length_squared() == 0.0 {
                return Err(self.bad(
                    who,
                    format!(
                        "sensor {} has direction {:?}: it must be finite and not zero",
                        k + 1,
                        s.dir
                    ),
                ));
            }
            self.out.sensors.push((p, d));
            self.out.imported.sensor_grid.push(index);
        }
        if g.sensors.is_empty() {
            self.out.warnings.push(format!(
                "{}: SensorGrid `{}` has no sensors",
                self.path.display(),
                g.identifier
            ));
        }
        let areas = match &g.mesh {
            Some(m) if m.faces.len() == g.sensors.len() && !g.sensors.is_empty() => {
                Some(self.cell_areas(m, who)?)
            }
            Some(m) => {
                self.out.warnings.push(format!(
                    "{}: SensorGrid `{}`: its mesh has {} faces for {} sensors; shares are \
                     by sensor count, not area",
                    self.path.display(),
                    g.identifier,
                    m.faces.len(),
                    g.sensors.len()
                ));
                None
            }
            None => None,
        };
        self.out.imported.grids.push(GridInfo {
            identifier: g.identifier,
            room: g.room_identifier,
            sensors: g.sensors.len(),
            areas,
        });
        Ok(())
    }

    /// Area of each face of a grid's mesh, m² (triangles and quads, a quad as two
    /// triangles: honeybee's cells are planar).
    fn cell_areas(&self, m: &Mesh3DJ, who: Who) -> Result<Vec<f64>> {
        let v: Vec<DVec3> = self.ring(&m.vertices, who)?;
        m.faces
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let p = |i: usize| {
                    v.get(f[i]).copied().ok_or_else(|| {
                        self.bad(
                            who,
                            format!(
                                "mesh face {k} refers to vertex {} of the {} given",
                                f[i],
                                v.len()
                            ),
                        )
                    })
                };
                let tri = |a: DVec3, b: DVec3, c: DVec3| 0.5 * (b - a).cross(c - a).length();
                match f.len() {
                    3 => Ok(tri(p(0)?, p(1)?, p(2)?)),
                    4 => Ok(tri(p(0)?, p(1)?, p(2)?) + tri(p(0)?, p(2)?, p(3)?)),
                    n => Err(self.bad(
                        who,
                        format!("mesh face {k} has {n} vertices: 3 or 4 expected"),
                    )),
                }
            })
            .collect()
    }

    pub(super) fn view(&mut self, v: Value, ctx: &dyn Fn() -> String) -> Result<()> {
        let j: ViewJ = self.parse(v, "View", ctx)?;
        let who: Who = (&j.identifier, "View");
        let kind = match j.view_type.as_deref().unwrap_or("v") {
            "v" => ViewType::Perspective,
            "h" => ViewType::Hemispherical,
            "l" => ViewType::Parallel,
            "a" => ViewType::Angular,
            other => {
                self.out.warnings.push(format!(
                    "{}: View `{}` has view type `{other}` (daystep renders v, h, l and a): \
                     left out",
                    self.path.display(),
                    j.identifier
                ));
                return Ok(());
            }
        };
        let size = |x: Option<f64>| {
            let x = x.unwrap_or(60.0);
            if kind == ViewType::Parallel {
                self.units.m(x)
            } else {
                x
            }
        };
        if j.fore_clip.unwrap_or(0.0) != 0.0 || j.aft_clip.unwrap_or(0.0) != 0.0 {
            self.out.warnings.push(format!(
                "{}: View `{}`: clipping planes (fore_clip, aft_clip) ignored",
                self.path.display(),
                j.identifier
            ));
        }
        let view = View {
            kind,
            vp: self.point(j.position, who)?,
            vd: DVec3::from_array(j.direction),
            vu: DVec3::from_array(j.up_vector),
            vh: size(j.h_size),
            vv: size(j.v_size),
            vs: j.shift.unwrap_or(0.0),
            vl: j.lift.unwrap_or(0.0),
        };
        let view = view.check(&self.path, None).map_err(|e| match e {
            Error::Input { message, .. } => self.bad(who, message),
            other => other,
        })?;
        self.out.imported.views.push(NamedView {
            identifier: j.identifier,
            room: j.room_identifier,
            view,
        });
        Ok(())
    }
    /// A shade: its own modifier, else (orphans) the context modifier when detached or
    /// the global exterior shade, else its room's set's (or the global) shade modifier.
    pub(super) fn shade(
        &mut self,
        v: Value,
        room: Option<u32>,
        parent: Parent,
        indoor: bool,
        ctx: &dyn Fn() -> String,
    ) -> Result<()> {
        let s: ShadeJ = self.parse(v, "Shade", ctx)?;
        let who: Who = (&s.identifier, "Shade");
        let rad = s.properties.radiance.as_ref();
        let own = rad.and_then(|r| r.modifier.clone());
        let fallback = match parent {
            Parent::Orphan if s.is_detached => self.mods.context(),
            Parent::Orphan => self.mods.set_modifier(None, Slot::ShadeExterior),
            Parent::Set(set) => self.mods.set_modifier(
                set,
                if indoor {
                    Slot::ShadeInterior
                } else {
                    Slot::ShadeExterior
                },
            ),
        };
        let material = self.material(own.as_deref(), fallback, who)?;
        if let Some(r) = rad {
            self.dynamic_group(&s.identifier, r);
        }
        let (boundary, holes) = self.face3d(&s.geometry, who)?;
        self.polygon(&boundary, &holes, material, who, room);
        Ok(())
    }

    pub(super) fn finish(mut self) -> Result<HbjsonContents> {
        if self.out.triangles.is_empty() {
            return Err(Error::input(
                &self.path,
                None,
                Some(&self.model),
                format!(
                    "Model `{}` has no geometry daystep can use (rooms, faces, apertures, \
                     doors or shades with area)",
                    self.model
                ),
            ));
        }
        let counts: ImportCounts = self.out.imported.counts;
        let totals = [
            counts.zero_area,
            counts.non_planar,
            counts.self_intersecting,
            counts.apertures_outside_parent,
        ];
        let names = [
            "polygons enclosing no area",
            "non-planar polygons",
            "self-intersecting polygons",
            "apertures or doors outside their face",
        ];
        for (n, name) in totals.iter().zip(names) {
            if *n > DETAILED_WARNINGS {
                self.out.warnings.push(format!(
                    "{}: {n} {name} in all ({DETAILED_WARNINGS} listed)",
                    self.path.display()
                ));
            }
        }
        self.out.warnings.append(&mut self.mods.warnings);
        self.out.materials = std::mem::take(&mut self.mods.materials);
        if !self.out.imported.rooms.is_empty() {
            self.out.imported.group_room = self.group_room;
        }
        Ok(self.out)
    }
}
