//! The choice of hair-hair model in a scene's `collision` block, and the volume model's
//! settings.

use hair_ssv::Real;

/// Which model hair-hair interaction uses.
#[derive(Clone, Debug, PartialEq)]
pub enum HairHairModel {
    /// Hair as a volume ([`crate::HairVolume`]): friction toward the grid's velocity and a
    /// push out of over-dense places. No pair search. The default: it costs what the hair
    /// costs, not what its contacts cost.
    Volume(VolumeSettings),
    /// The papers' exact model ([`crate::HairPairs`]), the reference: its settings are the
    /// collision block's `parallel_angle`, `hair_hair_push` and `pair_search_interval`.
    Pairs,
    /// No hair-hair interaction.
    Off,
}

impl Default for HairHairModel {
    fn default() -> Self {
        Self::Volume(VolumeSettings::default())
    }
}

impl HairHairModel {
    /// The model's name as `hair run --hair-hair` takes it: `volume`, `pairs` or `off`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Volume(_) => "volume",
            Self::Pairs => "pairs",
            Self::Off => "off",
        }
    }

    /// The model named `volume` (with default settings), `pairs` or `off`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "volume" => Some(Self::Volume(VolumeSettings::default())),
            "pairs" => Some(Self::Pairs),
            "off" => Some(Self::Off),
            _ => None,
        }
    }
}

/// The volume model's settings (SI units).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct VolumeSettings {
    /// The grid's spacing as a multiple of the active hair's mean segment length. Default 1.
    pub cell_size: Real,
    /// Most grid points: a wider spacing is taken when the hair's bounds would need more.
    /// Default 1,048,576 (16 MB of lattice points).
    pub max_cells: u32,
    /// The friction rate at the root (1/s): a node's velocity moves toward the grid's by the
    /// fraction `1 - exp(-rate dt)` each step, so the pull does not depend on the step.
    /// Default 10.
    pub friction_root: Real,
    /// The friction rate at the tip (1/s); in between, linear in the node's index. Default 4.
    pub friction_tip: Real,
    /// Whether over-dense hair is pushed apart. Default true.
    pub repulsion: bool,
    /// The density above which hair is pushed, as a multiple of the grid's mass-weighted mean
    /// density this step. Default 2.
    pub density_limit: Real,
    /// The push's largest speed, in grid spacings per second, reached where the density is
    /// twice the limit (less in proportion below). Default 1.
    pub repulsion_rate: Real,
}

impl Default for VolumeSettings {
    fn default() -> Self {
        Self {
            cell_size: 1.0,
            max_cells: 1 << 20,
            friction_root: 10.0,
            friction_tip: 4.0,
            repulsion: true,
            density_limit: 2.0,
            repulsion_rate: 1.0,
        }
    }
}

impl VolumeSettings {
    /// The first field out of its range, as `(field, message)`.
    pub(crate) fn check(&self) -> Option<(&'static str, String)> {
        let positive = |x: Real| x.is_finite() && x > 0.0;
        let non_negative = |x: Real| x.is_finite() && x >= 0.0;
        if !positive(self.cell_size) {
            return Some((
                "hair_hair.cell_size",
                format!("must be positive and finite, got {}", self.cell_size),
            ));
        }
        if self.max_cells < 8 {
            return Some((
                "hair_hair.max_cells",
                format!("must be at least 8, got {}", self.max_cells),
            ));
        }
        for (field, x) in [
            ("hair_hair.friction_root", self.friction_root),
            ("hair_hair.friction_tip", self.friction_tip),
            ("hair_hair.repulsion_rate", self.repulsion_rate),
        ] {
            if !non_negative(x) {
                return Some((field, format!("must be non-negative and finite, got {x}")));
            }
        }
        if !positive(self.density_limit) {
            return Some((
                "hair_hair.density_limit",
                format!("must be positive and finite, got {}", self.density_limit),
            ));
        }
        None
    }
}

/// Scene files write `hair_hair: Volume(friction_tip: 2.0)`, `Pairs` or `Off`; files from
/// before the volume model wrote `hair_hair: true` (now `Pairs`) or `false` (now `Off`).
#[cfg(feature = "serde")]
mod serde_impl {
    use super::{HairHairModel, VolumeSettings};
    use serde::de::{self, EnumAccess, VariantAccess};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    const VARIANTS: &[&str] = &["Volume", "Pairs", "Off"];
    const FIELDS: &[&str] = &[
        "cell_size",
        "max_cells",
        "friction_root",
        "friction_tip",
        "repulsion",
        "density_limit",
        "repulsion_rate",
    ];

    impl Serialize for HairHairModel {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            use serde::ser::SerializeStructVariant;
            match self {
                Self::Volume(v) => {
                    let mut st = s.serialize_struct_variant("HairHairModel", 0, "Volume", 7)?;
                    st.serialize_field("cell_size", &v.cell_size)?;
                    st.serialize_field("max_cells", &v.max_cells)?;
                    st.serialize_field("friction_root", &v.friction_root)?;
                    st.serialize_field("friction_tip", &v.friction_tip)?;
                    st.serialize_field("repulsion", &v.repulsion)?;
                    st.serialize_field("density_limit", &v.density_limit)?;
                    st.serialize_field("repulsion_rate", &v.repulsion_rate)?;
                    st.end()
                }
                Self::Pairs => s.serialize_unit_variant("HairHairModel", 1, "Pairs"),
                Self::Off => s.serialize_unit_variant("HairHairModel", 2, "Off"),
            }
        }
    }

    /// The variant's name, or the old flag.
    enum Tag {
        Volume,
        Pairs,
        Off,
    }

    impl<'de> Deserialize<'de> for Tag {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct TagVisitor;
            impl de::Visitor<'_> for TagVisitor {
                type Value = Tag;
                fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                    f.write_str("Volume(..), Pairs, Off, or the old true / false")
                }
                fn visit_str<E: de::Error>(self, v: &str) -> Result<Tag, E> {
                    match v {
                        "Volume" => Ok(Tag::Volume),
                        "Pairs" | "true" => Ok(Tag::Pairs),
                        "Off" | "false" => Ok(Tag::Off),
                        _ => Err(E::unknown_variant(v, VARIANTS)),
                    }
                }
                fn visit_bool<E: de::Error>(self, v: bool) -> Result<Tag, E> {
                    Ok(if v { Tag::Pairs } else { Tag::Off })
                }
            }
            d.deserialize_identifier(TagVisitor)
        }
    }

    /// Reads the struct variant's fields as a map into the derived [`VolumeSettings`]
    /// deserializer (defaults and unknown-field errors included).
    struct VolumeVisitor;

    impl<'de> de::Visitor<'de> for VolumeVisitor {
        type Value = VolumeSettings;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("the volume model's settings")
        }
        fn visit_map<A: de::MapAccess<'de>>(self, map: A) -> Result<VolumeSettings, A::Error> {
            VolumeSettings::deserialize(de::value::MapAccessDeserializer::new(map))
        }
        fn visit_unit<E: de::Error>(self) -> Result<VolumeSettings, E> {
            Ok(VolumeSettings::default())
        }
    }

    struct ModelVisitor;

    impl<'de> de::Visitor<'de> for ModelVisitor {
        type Value = HairHairModel;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("Volume(..), Pairs, Off, or the old true / false")
        }
        fn visit_bool<E: de::Error>(self, v: bool) -> Result<HairHairModel, E> {
            Ok(if v {
                HairHairModel::Pairs
            } else {
                HairHairModel::Off
            })
        }
        fn visit_str<E: de::Error>(self, v: &str) -> Result<HairHairModel, E> {
            match v {
                "Pairs" => Ok(HairHairModel::Pairs),
                "Off" => Ok(HairHairModel::Off),
                "Volume" => Ok(HairHairModel::Volume(VolumeSettings::default())),
                _ => Err(E::unknown_variant(v, VARIANTS)),
            }
        }
        fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<HairHairModel, A::Error> {
            let (tag, variant) = data.variant::<Tag>()?;
            match tag {
                Tag::Volume => Ok(HairHairModel::Volume(
                    variant.struct_variant(FIELDS, VolumeVisitor)?,
                )),
                Tag::Pairs => variant.unit_variant().map(|()| HairHairModel::Pairs),
                Tag::Off => variant.unit_variant().map(|()| HairHairModel::Off),
            }
        }
    }

    impl<'de> Deserialize<'de> for HairHairModel {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            d.deserialize_enum("HairHairModel", VARIANTS, ModelVisitor)
        }
    }
}
