//! The tools' state over a simulation: water, hairspray, mousse, hair dryer, grab and scissors, driven by a timeline of
//! [`ToolEvent`]s (Ward, Galoppo & Lin, *Interactive Virtual Hair Salon*, §3.1, §4.3-4.4, §6).
//!
//! Why a timeline: a styling session is then plain data (the scene's `tools` field, RON), replays
//! bit for bit, can be edited, and the same event type will carry an interactive window's or a
//! 6-DOF device's input (press, move, release).
//!
//! Each tool has a pose (position, direction, and for scissors an `up` that fixes the blades'
//! plane) and an area of influence: a cone (apex at the tool, axis along its direction, length
//! `reach`, cut-off angle `angle`) for water, spray, mousse, dryer and grab, and the triangle
//! between the open blades for scissors. The sections it touches come from the grid (cells first,
//! then the exact test), and the cells it touches wake (the volumes are handed to the activity
//! tracker at the next step).
//!
//! Effects act on the front skeletons' control points (a section is the segment that ends at a
//! control point, so touching a section touches that point) and are then carried to every other
//! level of the hierarchy, so a level-of-detail change finds them already there (§6.6), by
//! `hair_lod::inherit_edits`: the touched node's per-point wetness, stiffness factor and
//! thickness factor are copied to all its descendants, and every ancestor takes the
//! strand-weighted mean of its children (a point a child lost to a cut adds nothing). Wetness is
//! per strand (the paper's percentage, in kg of water per skeleton control point): the water of
//! the hair is `sum over skeletons of strands * wetness`, the same on every front. See
//! `docs/salon.md`.

use crate::script::vec3;
use crate::{SalonError, Tool, ToolAction, ToolError, ToolEvent, ToolScript};
use hair_collide::{BodyConstraint, CollisionSettings};
use hair_dynamics::{Bond, CutPoint, HeadMotion, Point, Real, SkeletonId, StrandState, Vector};
use hair_grid::{Cone, Grid, InfluenceVolume, Section};
use hair_lod::{Hierarchy, InheritScratch};
use hair_ssv::{CollisionMethod, MeshBody};

/// Counters of the salon, per step (serialized flat into the per-frame metrics).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SalonStats {
    /// Water of the hair (kg): strands times wetness over the front and every fallen piece.
    pub water_kg: f64,
    /// Length of the hair at rest (m): strands times skeleton rest length over the front and
    /// every fallen piece (the wet stretch is elastic and not counted); a cut leaves it unchanged.
    pub hair_length_m: f64,
    /// Live spray bonds.
    pub bonds: usize,
    /// Bonds made so far.
    pub bonds_made: u64,
    /// Bonds broken so far (pulled past their distance).
    pub bonds_broken: u64,
    /// Skeletons cut so far (front skeletons; each makes a fallen piece).
    pub cuts: u64,
    /// Scissor snips so far.
    pub snips: u64,
    /// Fallen pieces still simulated.
    pub fallen: usize,
    /// Fallen pieces swept off the floor so far.
    pub swept: usize,
    /// Control points held by the grab tool.
    pub grabbed: usize,
    /// Sections inside a tool's area this step.
    pub tool_sections: usize,
    /// Tools pressed at the end of this step.
    pub tools_pressed: usize,
    /// Milliseconds in the salon stage.
    pub ms_salon: f64,
}

/// Inputs of one salon stage, borrowed from the pipeline.
pub struct SalonInput<'a> {
    /// The LOD hierarchy (every node a skeleton of the state).
    pub hierarchy: &'a Hierarchy,
    /// The hierarchy nodes being simulated.
    pub front: &'a [u32],
    /// The grid over `sections`, rebuilt this step.
    pub grid: &'a Grid,
    /// The front's sections.
    pub sections: &'a [Section],
    /// The body fallen pieces land on.
    pub body: Option<&'a MeshBody>,
    /// The head's motion at the end of the step.
    pub head: &'a HeadMotion,
    /// Simulated time at the end of the step (s).
    pub time: Real,
    /// The step (s).
    pub dt: Real,
    /// How fallen pieces collide with the body (the pipeline's body constraint settings).
    pub collision: &'a CollisionSettings,
}

/// A piece of hair a cut made: a free skeleton of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FallenPiece {
    /// Its skeleton in the state.
    pub skeleton: SkeletonId,
    /// The hierarchy node it was cut from (whose strands it draws).
    pub source: u32,
    /// The control point of the source its first point was.
    pub first_source: u32,
    /// Whether it has been swept off the floor (no longer simulated nor drawn).
    pub swept: bool,
}

#[derive(Clone, Copy, Debug)]
struct Fallen {
    skeleton: u32,
    source: u32,
    first_source: u32,
    swept: bool,
}

#[derive(Clone, Copy, Debug)]
struct Grab {
    skeleton: u32,
    node: u32,
    offset: Vector,
}

/// The tools' state during a simulation: the script's cursor, the pressed tools, the per-node
/// styling factors, the fallen pieces and the grabbed points, and reused scratch buffers.
#[derive(Debug, Default)]
pub struct Salon {
    script: ToolScript,
    cursor: usize,
    pressed: [Option<u32>; 6],
    volumes: Vec<InfluenceVolume>,
    // Per state node.
    stiffness: Vec<Real>,
    thickness: Vec<Real>,
    base_k_theta: Vec<Real>,
    base_k_phi: Vec<Real>,
    /// The groom's joint angles and the rest angles that hold them (theta, phi), at the start.
    groom: Vec<[Real; 2]>,
    base_rest: Vec<[Real; 2]>,
    base_radius: Vec<Real>,
    curl: Vec<Real>,
    // Per hierarchy node.
    mark: Vec<bool>,
    dirty: Vec<u32>,
    stack: Vec<u32>,
    node_points: Vec<core::ops::Range<usize>>,
    inherit: InheritScratch,
    refresh: Vec<u32>,
    // Tools.
    fallen: Vec<Fallen>,
    grabs: Vec<Grab>,
    forced: Vec<u32>,
    hits: Vec<u32>,
    /// End nodes of the sections the pressed tools acted on in the last step, ascending.
    touched: Vec<u32>,
    cells: Vec<hair_grid::CellKey>,
    section_mark: Vec<bool>,
    bond_keys: Vec<(u32, u32)>,
    candidates: Vec<[u32; 2]>,
    bond_count: Vec<u8>,
    points: Vec<Point>,
    /// The unswept fallen pieces' skeletons, and the body constraint they collide through.
    falling: Vec<u32>,
    fallen_collision: BodyConstraint,
    stats: SalonStats,
    last_bonds: usize,
}

impl Salon {
    /// The tools of a validated script over a simulation's initial state, whose skeleton `s`
    /// has the radius `skeleton_radius[s]` as built.
    pub fn new(
        script: &ToolScript,
        state: &StrandState,
        h: &Hierarchy,
        skeleton_radius: &[Real],
    ) -> Self {
        let mut s = Salon {
            script: script.clone(),
            ..Salon::default()
        };
        s.reset(state, h, skeleton_radius);
        s
    }

    /// Back to the start of the script over `state` (the initial state). The per-node arrays
    /// are refilled in the buffers already held, so that the steps of a replay take no memory
    /// even where cuts grew them (`hair soak` replays a whole session after a reset).
    pub fn reset(&mut self, state: &StrandState, h: &Hierarchy, skeleton_radius: &[Real]) {
        let n = state.node_count();
        self.cursor = 0;
        self.pressed = [None; 6];
        self.volumes.clear();
        self.touched.clear();
        let refill = |v: &mut Vec<Real>, from: &[Real]| {
            v.clear();
            v.extend_from_slice(from);
        };
        self.stiffness.clear();
        self.stiffness.resize(n, 1.0);
        self.thickness.clear();
        self.thickness.resize(n, 1.0);
        refill(&mut self.base_k_theta, state.k_theta());
        refill(&mut self.base_k_phi, state.k_phi());
        let pair = |(x, y): (&Real, &Real)| [*x, *y];
        self.groom.clear();
        self.groom
            .extend(state.theta().iter().zip(state.phi()).map(pair));
        self.base_rest.clear();
        let rest = state.rest_theta().iter().zip(state.rest_phi());
        self.base_rest.extend(rest.map(pair));
        refill(&mut self.base_radius, state.radius());
        for (s, &r) in skeleton_radius.iter().enumerate() {
            if s < state.skeleton_count() {
                for i in state.nodes(SkeletonId(s as u32)) {
                    self.base_radius[i] = r;
                }
            }
        }
        let ca = self.script.settings.curl_angle.max(1e-6);
        self.curl.clear();
        // The groom's bends, not the rest angles: those also hold the groom up against its
        // weight (sag-free), which would make every strand count as curled.
        self.curl.extend(self.groom.iter().map(|[theta, phi]| {
            let b = (theta.powi(2) + phi.powi(2)).sqrt();
            (b / ca).min(1.0)
        }));
        self.mark.clear();
        self.mark.resize(h.node_count(), false);
        self.fallen.clear();
        self.grabs.clear();
        self.forced.clear();
        self.stats = SalonStats::default();
        self.last_bonds = state.bonds().len();
    }

    /// The script.
    pub fn script(&self) -> &ToolScript {
        &self.script
    }

    // view (issue 9): live events from an interactive session.
    /// Appends a live event to the script; `now` is the simulated time, before which every
    /// event has been consumed, so an event at or after it is still ahead. The script stays
    /// valid (time order, moves and releases of pressed tools) or the event is refused.
    pub fn push_event(&mut self, event: ToolEvent, now: Real) -> Result<(), SalonError> {
        let index = self.script.events.len();
        if event.time.is_nan() || event.time < now {
            return Err(SalonError::Value {
                index,
                tool: event.tool.name(),
                time: event.time,
                field: "time",
                message: format!("is before the simulated time {now} s: already past"),
            });
        }
        self.script.events.push(event);
        if let Err(e) = self.script.validate() {
            self.script.events.pop();
            return Err(e);
        }
        Ok(())
    }

    /// The areas of the pressed tools (head frame) as of the last step.
    pub fn volumes(&self) -> &[InfluenceVolume] {
        &self.volumes
    }

    /// The end nodes (state node indices, ascending) of the sections that the water, spray,
    /// mousse, dryer and grab acted on in the last step: the hair localization must keep
    /// awake.
    pub fn touched_nodes(&self) -> &[u32] {
        &self.touched
    }

    /// The fallen pieces (swept ones included), in the order they fell.
    pub fn fallen_pieces(&self) -> impl Iterator<Item = FallenPiece> + '_ {
        self.fallen.iter().map(|f| FallenPiece {
            skeleton: SkeletonId(f.skeleton),
            source: f.source,
            first_source: f.first_source,
            swept: f.swept,
        })
    }

    /// Skeletons of the fallen pieces (swept ones included).
    pub fn fallen_skeletons(&self) -> impl Iterator<Item = SkeletonId> + '_ {
        self.fallen.iter().map(|f| SkeletonId(f.skeleton))
    }

    /// The grabbed control points: (skeleton, global node index).
    pub fn grabbed(&self, state: &StrandState) -> Vec<(SkeletonId, usize)> {
        self.grabs
            .iter()
            .map(|g| {
                let id = SkeletonId(g.skeleton);
                (id, state.nodes(id).start + g.node as usize)
            })
            .collect()
    }

    /// Per-node spring factor (1 = as built).
    pub fn stiffness(&self) -> &[Real] {
        &self.stiffness
    }

    /// Per-node radius factor (1 = as built).
    pub fn thickness(&self) -> &[Real] {
        &self.thickness
    }

    /// The counters as of the last step.
    pub fn stats(&self) -> SalonStats {
        self.stats
    }

    /// One salon stage, after the dynamics of a step: the script's events up to the end of the
    /// step, then every pressed tool for one step, then the effects carried through the
    /// hierarchy, and the fallen pieces kept out of the body.
    pub fn step(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
    ) -> Result<SalonStats, ToolError> {
        let t0 = std::time::Instant::now();
        // Bonds that the dynamics broke since the last stage.
        let live = state.bonds().len();
        self.stats.bonds_broken += self.last_bonds.saturating_sub(live) as u64;
        self.stats.tool_sections = 0;
        self.grow(state);
        // Events up to the end of this step.
        while let Some(e) = self.script.events.get(self.cursor) {
            if e.time >= inp.time {
                break;
            }
            let index = self.cursor;
            self.cursor += 1;
            let (tool, action) = (e.tool, e.action);
            match action {
                ToolAction::Press | ToolAction::Move => {
                    self.pressed[tool.index()] = Some(index as u32);
                    match tool {
                        Tool::Scissors => self.snip(state, inp, index)?,
                        Tool::Grab if action == ToolAction::Press => {
                            self.take(state, inp, index)?;
                        }
                        _ => {}
                    }
                }
                ToolAction::Release => {
                    self.pressed[tool.index()] = None;
                    match tool {
                        Tool::Grab => self.grabs.clear(),
                        Tool::Dryer => self.clear_forces(state),
                        _ => {}
                    }
                }
            }
        }
        // The pressed tools' areas now.
        self.volumes.clear();
        for tool in Tool::ALL {
            if let Some(i) = self.pressed[tool.index()] {
                let v = self.volume(i as usize, inp.time, inp.head);
                self.volumes.push(v);
            }
        }
        // Continuous tools, in a fixed order.
        if self.pressed[Tool::Dryer.index()].is_none() && !self.forced.is_empty() {
            self.clear_forces(state);
        }
        self.touched.clear();
        for tool in [Tool::Water, Tool::Spray, Tool::Mousse, Tool::Dryer] {
            if let Some(i) = self.pressed[tool.index()] {
                self.apply(state, inp, tool, i as usize)?;
            }
        }
        if let Some(i) = self.pressed[Tool::Grab.index()] {
            self.hold(state, inp, i as usize)?;
            if let InfluenceVolume::Cone(cone) = self.volume(i as usize, inp.time, inp.head) {
                let mut hits = std::mem::take(&mut self.hits);
                self.sections_in_cone(state, inp, &cone, &mut hits)?;
                self.touch(state, inp.sections, &hits);
                self.hits = hits;
            }
        }
        self.touched.sort_unstable();
        self.touched.dedup();
        self.propagate(state, inp.hierarchy)?;
        self.collide_fallen(state, inp)?;
        // Counters.
        self.last_bonds = state.bonds().len();
        self.stats.bonds = self.last_bonds;
        self.stats.grabbed = self.grabs.len();
        self.stats.tools_pressed = self.pressed.iter().filter(|p| p.is_some()).count();
        let (water, length) = self.totals(state, inp.hierarchy, inp.front);
        self.stats.water_kg = water;
        self.stats.hair_length_m = length;
        self.stats.fallen = self.fallen.iter().filter(|f| !f.swept).count();
        self.stats.swept = self.fallen.len() - self.stats.fallen;
        self.stats.ms_salon = t0.elapsed().as_secs_f64() * 1e3;
        Ok(self.stats)
    }

    /// Water (kg) and rest length (m) of the hair: strands times wetness and times skeleton rest
    /// length over the nodes of `front` and every fallen piece.
    pub fn totals(&self, state: &StrandState, h: &Hierarchy, front: &[u32]) -> (f64, f64) {
        let mut water = 0.0f64;
        let mut length = 0.0f64;
        let mut add = |id: SkeletonId, strands: f64| {
            let r = state.nodes(id);
            let w: f64 = state.wetness()[r.clone()]
                .iter()
                .map(|&x| f64::from(x))
                .sum();
            let l: f64 = state.rest_length()[r.start + 1..r.end]
                .iter()
                .map(|&x| f64::from(x))
                .sum();
            water += strands * w;
            length += strands * l;
        };
        for &n in front {
            add(SkeletonId(n), f64::from(h.strand_count(n)));
        }
        for f in &self.fallen {
            add(SkeletonId(f.skeleton), f64::from(h.strand_count(f.source)));
        }
        (water, length)
    }

    /// Extends the per-node arrays to the state's node count (after a cut added a piece).
    fn grow(&mut self, state: &StrandState) {
        let n = state.node_count();
        if self.stiffness.len() < n {
            self.stiffness.resize(n, 1.0);
            self.thickness.resize(n, 1.0);
            self.base_k_theta.resize(n, 0.0);
            self.base_k_phi.resize(n, 0.0);
            self.groom.resize(n, [0.0; 2]);
            self.base_rest.resize(n, [0.0; 2]);
            self.base_radius.resize(n, 0.0);
            self.curl.resize(n, 0.0);
        }
    }

    /// The area of the tool of event `i` at time `t`, in the head frame.
    fn volume(&self, i: usize, t: Real, head: &HeadMotion) -> InfluenceVolume {
        let e = &self.script.events[i];
        let pose = e.pose_at(t);
        let inv = head.rotation.inverse();
        let apex = Point::from(inv * (vec3(&pose.position) - head.position.coords));
        let dir = (inv * vec3(&pose.direction))
            .try_normalize(1e-12)
            .unwrap_or_else(|| -Vector::z());
        if e.tool == Tool::Scissors {
            let up = inv * vec3(&pose.up);
            let side = up
                .cross(&dir)
                .try_normalize(1e-12)
                .unwrap_or_else(Vector::x);
            let (s, c) = e.angle.sin_cos();
            InfluenceVolume::Triangle([
                apex,
                apex + (dir * c + side * s) * e.reach,
                apex + (dir * c - side * s) * e.reach,
            ])
        } else {
            InfluenceVolume::Cone(Cone::from_angle(apex, dir, e.reach, e.angle))
        }
    }

    /// Whether section `sec` is still a live segment of its skeleton (a cut this step may have
    /// removed it); returns its skeleton and local segment end.
    /// Records the end nodes of the live sections `hits` as touched.
    fn touch(&mut self, state: &StrandState, sections: &[Section], hits: &[u32]) {
        let live = hits
            .iter()
            .filter_map(|&h| Self::live(state, sections, h as usize));
        self.touched
            .extend(live.map(|(id, k)| (state.nodes(id).start + k) as u32));
    }

    fn live(state: &StrandState, sections: &[Section], sec: usize) -> Option<(SkeletonId, usize)> {
        let s = &sections[sec];
        let id = SkeletonId(s.skeleton);
        let k = s.segment as usize + 1;
        (k < state.nodes(id).len()).then_some((id, k))
    }

    /// The live sections whose end control point (at its current position, grown by its
    /// radius) lies in the cone: candidates from the grid cells the cone covers, then the exact
    /// point test. Ascending, into `out`.
    fn sections_in_cone(
        &mut self,
        state: &StrandState,
        inp: &SalonInput<'_>,
        cone: &Cone,
        out: &mut Vec<u32>,
    ) -> Result<(), ToolError> {
        inp.grid
            .cells_touched_by(&InfluenceVolume::Cone(*cone), &mut self.cells)?;
        out.clear();
        for &key in &self.cells {
            out.extend_from_slice(inp.grid.cell_sections(key));
        }
        out.sort_unstable();
        out.dedup();
        out.retain(|&sec| {
            Self::live(state, inp.sections, sec as usize).is_some_and(|(id, k)| {
                let i = state.nodes(id).start + k;
                let p = state.positions()[i];
                cone.contains_point(&p) || cone.distance_to_point(&p) <= state.radius()[i]
            })
        });
        Ok(())
    }

    fn mark_dirty(&mut self, node: u32) {
        if let Some(m) = self.mark.get_mut(node as usize)
            && !*m
        {
            *m = true;
            self.dirty.push(node);
        }
    }

    /// Applies a continuous tool for one step to the sections in its cone.
    fn apply(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
        tool: Tool,
        i: usize,
    ) -> Result<(), ToolError> {
        let vol = self.volume(i, inp.time, inp.head);
        let InfluenceVolume::Cone(cone) = vol else {
            return Ok(());
        };
        let (strength, reach) = {
            let e = &self.script.events[i];
            (e.strength, e.reach)
        };
        let st = self.script.settings;
        let dt = inp.dt;
        let mut hits = std::mem::take(&mut self.hits);
        self.sections_in_cone(state, inp, &cone, &mut hits)?;
        if let Some(body) = inp.body {
            hits.retain(|&sec| {
                Self::live(state, inp.sections, sec as usize).is_none_or(|(id, k)| {
                    let p = state.positions()[state.nodes(id).start + k];
                    in_sight(body, inp.collision.method, &p, &cone.apex)
                })
            });
        }
        self.stats.tool_sections += hits.len();
        self.touch(state, inp.sections, &hits);
        let axis = cone.axis.normalize();
        if tool == Tool::Dryer {
            self.clear_forces(state);
        }
        for &sec in &hits {
            let Some((id, k)) = Self::live(state, inp.sections, sec as usize) else {
                continue;
            };
            let node = state.nodes(id).start + k;
            match tool {
                Tool::Water => {
                    let cap = st.saturation * state.mass()[node];
                    let w = &mut state.wetness_mut()[node];
                    *w = (*w + strength * st.water_rate * dt).min(cap.max(*w));
                    self.stiffness[node] = 1.0; // water undoes hairspray's stiffening
                }
                Tool::Spray => {
                    let f = &mut self.stiffness[node];
                    *f = (*f + strength * st.spray_rate * dt).min(st.max_stiffness.max(*f));
                }
                Tool::Mousse => {
                    let f = &mut self.thickness[node];
                    *f = (*f + strength * st.mousse_rate * dt).min(st.max_thickness.max(*f));
                }
                Tool::Dryer => {
                    let along = (state.positions()[node] - cone.apex).dot(&axis);
                    let fade = if reach > 0.0 {
                        (1.0 - along / reach).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    state.external_force_mut()[node] = axis * (strength * st.dryer_force * fade);
                    self.forced.push(node as u32);
                    let w = &mut state.wetness_mut()[node];
                    *w = (*w - strength * st.dry_rate * fade * dt).max(0.0);
                }
                Tool::Grab | Tool::Scissors => {}
            }
            self.mark_dirty(id.0);
        }
        if tool == Tool::Spray {
            self.bond(state, inp, &hits)?;
        }
        self.hits = hits;
        Ok(())
    }

    /// Spray bonds: between the end nodes of every pair of sprayed sections in contact now, on
    /// different skeletons, up to `bonds_per_node` per node, never twice between two nodes.
    fn bond(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
        hits: &[u32],
    ) -> Result<(), ToolError> {
        let st = self.script.settings;
        self.section_mark.clear();
        self.section_mark.resize(inp.sections.len(), false);
        for &h in hits {
            self.section_mark[h as usize] = true;
        }
        self.bond_keys.clear();
        self.bond_count.clear();
        self.bond_count.resize(state.node_count(), 0);
        for b in state.bonds() {
            self.bond_keys.push((b.a.min(b.b), b.a.max(b.b)));
            self.bond_count[b.a as usize] = self.bond_count[b.a as usize].saturating_add(1);
            self.bond_count[b.b as usize] = self.bond_count[b.b as usize].saturating_add(1);
        }
        self.bond_keys.sort_unstable();
        let limit = st.bonds_per_node.min(255) as u8;
        // Candidate pairs: sprayed sections sharing a grid cell (each pair once, ascending).
        self.candidates.clear();
        for &a in hits {
            for key in inp.grid.section_cells(a as usize) {
                for &b in inp.grid.cell_sections(key) {
                    if b > a && self.section_mark[b as usize] {
                        self.candidates.push([a, b]);
                    }
                }
            }
        }
        self.candidates.sort_unstable();
        self.candidates.dedup();
        let candidates = std::mem::take(&mut self.candidates);
        for &[a, b] in &candidates {
            let (a, b) = (a as usize, b as usize);
            if inp.sections[a].skeleton == inp.sections[b].skeleton {
                continue;
            }
            // In contact now: the sections' swept volumes overlap.
            let (sa, sb) = (&inp.sections[a].shape, &inp.sections[b].shape);
            let c = sa.closest_points(sb);
            if (c.on_b - c.on_a).norm() > sa.radius() + sb.radius() {
                continue;
            }
            let (Some((ia, ka)), Some((ib, kb))) = (
                Self::live(state, inp.sections, a),
                Self::live(state, inp.sections, b),
            ) else {
                continue;
            };
            let na = (state.nodes(ia).start + ka) as u32;
            let nb = (state.nodes(ib).start + kb) as u32;
            let key = (na.min(nb), na.max(nb));
            if self.bond_count[na as usize] >= limit
                || self.bond_count[nb as usize] >= limit
                || self.bond_keys.binary_search(&key).is_ok()
            {
                continue;
            }
            let rest = (state.positions()[na as usize] - state.positions()[nb as usize]).norm();
            state.add_bond(Bond {
                a: key.0,
                b: key.1,
                rest,
                stiffness: st.bond_stiffness,
                break_distance: rest + st.bond_break_stretch,
            })?;
            let pos = self.bond_keys.binary_search(&key).unwrap_or_else(|p| p);
            self.bond_keys.insert(pos, key);
            self.bond_count[na as usize] += 1;
            self.bond_count[nb as usize] += 1;
            self.stats.bonds_made += 1;
        }
        self.candidates = candidates;
        Ok(())
    }

    fn clear_forces(&mut self, state: &mut StrandState) {
        let n = state.node_count();
        for &i in &self.forced {
            if (i as usize) < n {
                state.external_force_mut()[i as usize] = Vector::zeros();
            }
        }
        self.forced.clear();
    }

    /// Grab press: one control point per skeleton inside the cone, the closest to its axis.
    fn take(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
        i: usize,
    ) -> Result<(), ToolError> {
        self.grabs.clear();
        let vol = self.volume(i, inp.time, inp.head);
        let InfluenceVolume::Cone(cone) = vol else {
            return Ok(());
        };
        let mut hits = std::mem::take(&mut self.hits);
        self.sections_in_cone(state, inp, &cone, &mut hits)?;
        let axis = cone.axis.normalize();
        let mut best: Option<(u32, u32, Real)> = None;
        let flush = |best: &mut Option<(u32, u32, Real)>, grabs: &mut Vec<Grab>| {
            if let Some((skel, node, _)) = best.take() {
                let p = state.positions()[state.nodes(SkeletonId(skel)).start + node as usize];
                grabs.push(Grab {
                    skeleton: skel,
                    node,
                    offset: p - cone.apex,
                });
            }
        };
        for &sec in &hits {
            let Some((id, k)) = Self::live(state, inp.sections, sec as usize) else {
                continue;
            };
            if best.is_some_and(|b| b.0 != id.0) {
                flush(&mut best, &mut self.grabs);
            }
            let p = state.positions()[state.nodes(id).start + k];
            if !cone.contains_point(&p) {
                continue;
            }
            let w = p - cone.apex;
            let off_axis = (w - axis * w.dot(&axis)).norm();
            if best.is_none_or(|b| off_axis < b.2) {
                best = Some((id.0, k as u32, off_axis));
            }
        }
        flush(&mut best, &mut self.grabs);
        self.hits = hits;
        Ok(())
    }

    /// Grabbed points follow the tool, within their reach.
    fn hold(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
        i: usize,
    ) -> Result<(), ToolError> {
        let InfluenceVolume::Cone(cone) = self.volume(i, inp.time, inp.head) else {
            return Ok(());
        };
        self.grabs
            .retain(|g| (g.node as usize) < state.nodes(SkeletonId(g.skeleton)).len());
        for g in &self.grabs {
            state.hold_node(
                SkeletonId(g.skeleton),
                g.node as usize,
                cone.apex + g.offset,
                &mut self.points,
            )?;
        }
        Ok(())
    }

    /// A snip: every front skeleton crossing the blades' triangle is cut at its first crossing
    /// from the root; the part below falls as a free skeleton; the cut is inherited by the
    /// node's descendants (the same trailing points removed).
    fn snip(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
        i: usize,
    ) -> Result<(), ToolError> {
        self.stats.snips += 1;
        let vol = self.volume(i, inp.time, inp.head);
        let InfluenceVolume::Triangle(tri) = vol else {
            return Ok(());
        };
        let mut hits = std::mem::take(&mut self.hits);
        inp.grid.sections_in(&vol, &mut hits)?;
        self.stats.tool_sections += hits.len();
        let min_len = self.script.settings.min_cut_length;
        let mut last_cut: Option<u32> = None;
        for &sec in &hits {
            let s = &inp.sections[sec as usize];
            if last_cut == Some(s.skeleton) {
                continue; // first crossing from the root only
            }
            let Some((id, k)) = Self::live(state, inp.sections, sec as usize) else {
                continue;
            };
            let r = state.nodes(id);
            let (a, b) = (
                state.positions()[r.start + k - 1],
                state.positions()[r.start + k],
            );
            let Some(t) = segment_triangle(&a, &b, &tri) else {
                continue;
            };
            let Some(at) =
                (CutPoint { segment: k, t }).snapped(&state.length()[r.clone()], min_len)
            else {
                continue;
            };
            last_cut = Some(id.0);
            let res = state.cut(id, at, true)?;
            if let Some(f) = res.fallen {
                self.grow(state);
                let fr = state.nodes(f);
                for j in 0..fr.len() {
                    let src = if j == 0 {
                        r.start + at.segment
                    } else {
                        r.start + res.first_source + j - 1
                    };
                    let dst = fr.start + j;
                    self.stiffness[dst] = self.stiffness[src];
                    self.thickness[dst] = self.thickness[src];
                    self.base_k_theta[dst] = self.base_k_theta[src];
                    self.base_k_phi[dst] = self.base_k_phi[src];
                    // A fallen piece holds no load: its rest angles as copied, no preload.
                    let rest = [state.rest_theta()[dst], state.rest_phi()[dst]];
                    (self.groom[dst], self.base_rest[dst]) = (rest, rest);
                    self.base_radius[dst] = self.base_radius[src];
                    self.curl[dst] = if j >= 2 { self.curl[src] } else { 0.0 };
                }
                self.fallen.push(Fallen {
                    skeleton: f.0,
                    source: id.0,
                    first_source: res.first_source as u32,
                    swept: false,
                });
                state.set_active(f, true);
            }
            self.stats.cuts += 1;
            // Inherit the cut down the hierarchy (inactive levels: no fallen piece of their own).
            let h = inp.hierarchy;
            if (id.0 as usize) < h.node_count() {
                self.stack.clear();
                self.stack.extend(h.children(id.0));
                while let Some(d) = self.stack.pop() {
                    self.stack.extend(h.children(d));
                    let n = state.nodes(SkeletonId(d)).len();
                    if at.segment < n && !(at.t >= 1.0 && at.segment + 1 >= n) {
                        state.cut(SkeletonId(d), at, false)?;
                    }
                }
                self.mark_dirty(id.0);
            }
            self.grabs.retain(|g| {
                g.skeleton != id.0 || (g.node as usize) < state.nodes(SkeletonId(g.skeleton)).len()
            });
        }
        self.hits = hits;
        Ok(())
    }

    /// Carries the touched nodes' properties through the hierarchy (`hair_lod::inherit_edits`:
    /// copied down, strand-weighted means up) and refreshes what they drive on every node
    /// changed: springs, radius and wet stretch.
    fn propagate(&mut self, state: &mut StrandState, h: &Hierarchy) -> Result<(), ToolError> {
        if self.dirty.is_empty() {
            return Ok(());
        }
        // The skeletons' ranges, read before the wetness is borrowed for writing.
        self.node_points.clear();
        self.node_points
            .extend((0..h.node_count() as u32).map(|n| state.nodes(SkeletonId(n))));
        let node_points = &self.node_points;
        let result = hair_lod::inherit_edits(
            h,
            &self.dirty,
            |n| node_points.get(n as usize).cloned().unwrap_or(0..0),
            &mut [
                state.wetness_mut(),
                &mut self.stiffness[..],
                &mut self.thickness[..],
            ],
            &mut self.inherit,
            &mut self.refresh,
        );
        for &d in &self.dirty {
            self.mark[d as usize] = false;
        }
        self.dirty.clear();
        result?;
        for ri in 0..self.refresh.len() {
            self.refresh_node(state, SkeletonId(self.refresh[ri]));
        }
        Ok(())
    }

    /// Springs, radius and wet stretch of one skeleton from its factors and water.
    fn refresh_node(&self, state: &mut StrandState, id: SkeletonId) {
        let st = &self.script.settings;
        let r = state.nodes(id);
        let mut moved = false;
        for i in r.clone() {
            let m = state.mass()[i];
            let w = state.wetness()[i];
            let wet = if m + w > 0.0 { w / (m + w) } else { 0.0 };
            let f = self.stiffness[i];
            state.k_theta_mut()[i] = self.base_k_theta[i] * f;
            state.k_phi_mut()[i] = self.base_k_phi[i] * f;
            // The rest angles hold the groom against its load (sag-free); a spring made f times
            // stiffer keeps the same torque there with an offset f times smaller, so sprayed
            // hair stays where it was groomed instead of springing up over the crown. (A
            // coarse skeleton's points past its children's cut ends average to a factor of 0.)
            let ([g_theta, g_phi], [b_theta, b_phi]) = (self.groom[i], self.base_rest[i]);
            let held = |g: Real, b: Real| {
                if f == 1.0 || f <= 0.0 {
                    b
                } else {
                    g - (g - b) / f
                }
            };
            state.rest_theta_mut()[i] = held(g_theta, b_theta);
            state.rest_phi_mut()[i] = held(g_phi, b_phi);
            state.radius_mut()[i] =
                self.base_radius[i] * self.thickness[i] * (1.0 - st.wet_shrink * wet);
            if i == r.start {
                continue;
            }
            let c = self.curl[i] * wet;
            if c > 1e-4 && st.wet_stretch_stiffness > 0.0 {
                state.k_stretch_mut()[i] = st.wet_stretch_stiffness / c;
            } else if state.k_stretch()[i] != 0.0 {
                state.k_stretch_mut()[i] = 0.0;
                let rest = state.rest_length()[i];
                state.length_mut()[i] = rest;
                moved = true;
            }
        }
        if moved {
            state.refresh_positions(id);
        }
    }

    /// Fallen pieces collide with the body through the pipeline's body constraint (a fallen
    /// piece is a free skeleton: swept root to tip like any other) and are swept away once
    /// entirely below the floor.
    fn collide_fallen(
        &mut self,
        state: &mut StrandState,
        inp: &SalonInput<'_>,
    ) -> Result<(), ToolError> {
        if self.fallen.is_empty() {
            return Ok(());
        }
        let floor = self.script.settings.floor_height;
        self.falling.clear();
        for f in &mut self.fallen {
            if f.swept {
                continue;
            }
            let id = SkeletonId(f.skeleton);
            let r = state.nodes(id);
            if state.positions()[r].iter().all(|p| p.y < floor) {
                f.swept = true;
                state.set_active(id, false);
                continue;
            }
            self.falling.push(f.skeleton);
        }
        let Some(body) = inp.body else {
            return Ok(());
        };
        // The pieces fell after the depenetration ramp: they are resolved at once.
        let past_ramp = u64::from(inp.collision.depenetration_steps);
        self.fallen_collision
            .apply(state, body, &self.falling, past_ramp, inp.collision)?;
        Ok(())
    }
}

/// Spacing (m) of the samples along the line from a tool to a point, and the depth inside the
/// body (m) at which a sample counts as blocked. The body's distance answers within 2 cm of its
/// surface, so a line into the body meets a sample between 5 mm and 2 cm deep.
const SIGHT_STEP: Real = 0.01;
const SIGHT_DEPTH: Real = 0.005;
/// Length (m) of the line's end, at the hair, left unsampled: hair lies on the body there.
const SIGHT_END: Real = 0.02;

/// Whether a tool at `apex` reaches the hair at `p`: not when the line between them passes
/// through the body (water, spray, mousse and air do not go through the head to the hair on
/// its far side). The last [`SIGHT_END`] before `p` is not sampled.
fn in_sight(body: &MeshBody, method: CollisionMethod, p: &Point, apex: &Point) -> bool {
    let line = p - apex;
    let length = line.norm();
    let clear = length - SIGHT_END;
    if clear.is_nan() || clear <= 0.0 {
        return true;
    }
    let samples = (clear / SIGHT_STEP).ceil() as usize;
    (1..=samples).all(|k| {
        let q = apex + line * ((k as Real * SIGHT_STEP).min(clear) / length);
        body.distance(method, &q)
            .is_none_or(|(d, _)| d > -SIGHT_DEPTH)
    })
}

/// Where segment `a -> b` crosses the triangle: the fraction along it, if it does.
fn segment_triangle(a: &Point, b: &Point, t: &[Point; 3]) -> Option<Real> {
    let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let da = (a - t[0]).dot(&n);
    let db = (b - t[0]).dot(&n);
    if (da > 0.0 && db > 0.0) || (da < 0.0 && db < 0.0) || da == db {
        return None;
    }
    let s = da / (da - db);
    let p = a + (b - a) * s;
    // Inside test by the signs of the three edge normals.
    let inside = (0..3).all(|e| {
        let (u, v) = (t[e], t[(e + 1) % 3]);
        (v - u).cross(&(p - u)).dot(&n) >= 0.0
    });
    inside.then_some(s.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Pose, PoseKey};

    #[test]
    fn a_segment_through_a_triangle_crosses_it_once() {
        let tri = [
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(0.0, 0.0, 1.0),
        ];
        let t = segment_triangle(
            &Point::new(0.2, 1.0, 0.2),
            &Point::new(0.2, -3.0, 0.2),
            &tri,
        );
        assert_eq!(t, Some(0.25));
        assert_eq!(
            segment_triangle(
                &Point::new(2.0, 1.0, 2.0),
                &Point::new(2.0, -1.0, 2.0),
                &tri
            ),
            None
        );
        assert_eq!(
            segment_triangle(&Point::new(0.2, 1.0, 0.2), &Point::new(0.2, 0.5, 0.2), &tri),
            None
        );
    }

    #[test]
    fn a_path_is_followed_and_held_at_its_end() {
        let e = ToolEvent {
            time: 1.0,
            tool: Tool::Water,
            action: ToolAction::Press,
            pose: Pose::default(),
            path: vec![PoseKey {
                time: 2.0,
                pose: Pose {
                    position: [1.0, 0.0, 0.0],
                    ..Pose::default()
                },
            }],
            strength: 1.0,
            reach: 0.1,
            angle: 0.3,
        };
        assert_eq!(e.pose_at(0.5).position, [0.0, 0.0, 0.0]);
        assert_eq!(e.pose_at(1.5).position, [0.5, 0.0, 0.0]);
        assert_eq!(e.pose_at(3.0).position, [1.0, 0.0, 0.0]);
    }
}
