//! A body as several parts, each with its own collision table and frame (Kurihara et al. 1993
//! §3.1: "we divide human body ... into several parts").

use crate::{CylinderMap, MapSample, Point, SphereMap, SurfaceMap};

/// The table of one part.
#[derive(Clone, Debug, PartialEq)]
pub enum PartMap {
    /// A cylindrical table.
    Cylinder(CylinderMap),
    /// A spherical table.
    Sphere(SphereMap),
}

impl SurfaceMap for PartMap {
    #[inline]
    fn lookup(&self, p: &Point) -> Option<MapSample> {
        match self {
            PartMap::Cylinder(m) => m.lookup(p),
            PartMap::Sphere(m) => m.lookup(p),
        }
    }
}

/// A named part of a body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyPart {
    /// Name, for reports.
    pub name: String,
    /// Its table.
    pub map: PartMap,
}

/// A body: the union of its parts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Body {
    /// The parts.
    pub parts: Vec<BodyPart>,
}

impl Body {
    /// The part covering `p` with the smallest signed distance (the union's surface), with its
    /// index; `None` when no part covers `p`.
    #[inline]
    pub fn lookup_part(&self, p: &Point) -> Option<(usize, MapSample)> {
        let mut best: Option<(usize, MapSample)> = None;
        for (i, part) in self.parts.iter().enumerate() {
            if let Some(s) = part.map.lookup(p)
                && best.is_none_or(|(_, b)| s.distance < b.distance)
            {
                best = Some((i, s));
            }
        }
        best
    }
}

impl SurfaceMap for Body {
    #[inline]
    fn lookup(&self, p: &Point) -> Option<MapSample> {
        self.lookup_part(p).map(|(_, s)| s)
    }

    /// Inside any part.
    fn inside(&self, p: &Point) -> bool {
        self.parts.iter().any(|part| part.map.inside(p))
    }
}
