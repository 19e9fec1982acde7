//! daystep's one integration-test binary (one binary links faster on 2-core CI).

mod scenes; // the generated office and building, shared with the benches
mod util; // scene builders in code, closed-form helpers, assert helpers

mod annual; // annual runs: resume after Ctrl-C and a cut line, shards merged (also 4 processes at once), a day vs cold instants
mod bias; // ground glow deep inside (behind a door) against an independent path tracer
mod cache; // projection cache: round trips, bad files rebuilt, eviction, concurrent writers (nothing lost or duplicated), CLI
mod cache_runs; // the cache in whole runs: warm = cold, Kd/site/weather hit, vertex misses, damage, 4 processes
mod coefficients; // daylight coefficients against forward solves: sky part, sun interpolation, coverage; steps summed together = alone
mod coincident; // coincident faces: floor on ground, desk on floor, walls back to back
mod cli; // the binary end to end: exit codes, messages naming file:line, outputs
mod df; // daylight factor: 100 % in the open, the vertical formula, roof-opening sky component, CLI
mod extent; // site context of any size: the office on a 1 km ground and in a ring of blocks
mod extremes; // low sun, polar day and night, turbidity limits, slivers, far coordinates
mod imagesky; // HDR image skies: uniform image πL, images of the CIE overcast sky in both mappings
mod generated_scenes; // the generated office and building: areas, normals, closure, triangle target, bundled files
mod leed; // annual --leed: light paths of two aperture groups sum to the room, the 2 % rule, DA from paths and schedule; EN 17037 needs a whole year
mod layers; // the layer rule of lib.rs: lower layers never import higher ones
mod memory; // --max-memory: refused before the work naming the smallest cap, same bytes at that cap, reported
mod model_outputs; // a Honeybee model through the binary: grid column, --grids, per-grid annual outputs, --view-name
mod models; // Honeybee HBJSON: as geometry and as SCENE, grids as sensors, mm = m, sky through a roof hole, exit 1 naming the object
mod outputs; // outputs checked before the work; a resumed render keeps only frames of the same inputs
mod parsers; // every parser under arbitrary and mutated input: no panic, hang or unbounded allocation
mod rad_models; // Radiance .rad/.mat as geometry: honeybee's .rad = its HBJSON, sky through a roof hole, exit 1 naming file:line, arbitrary and mutated .rad
mod render; // renders against closed forms: ρL, ρE cos θ/π, τ(θ)L, -i, threads
mod pictures; // pictures cannot exhaust memory: huge or short RGBE and OpenEXR refused with exit 1 under ulimit -v
mod numbers; // every number a user types is checked: flags, view files, scene-file values, exit 1 before any work
mod physics; // closed-form daylight: unobstructed skies, roof opening, thin sky band, sun footprint, glazing
mod transport; // global-line transport: furnace, configuration factor, closed rooms (exact enclosure), strata, warm = cold, threads
mod twosided; // two-sided surfaces: back-face closed form, normal flips, one surface or two, emitter front only
mod viewer; // `daystep view`: a file that is not a GLB refused at start (exit 1); a foreign Host gets 403, its own the file
mod warm_day; // 96 warm-started 15-minute steps of a clear day against cold solves
