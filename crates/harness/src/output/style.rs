//! One visual identity per method: the style table every figure, results page and 3D viewer
//! page takes its colours, markers and dashes from.
//!
//! A series' style is a function of its family and its variant only ([`style`]), never of its
//! place in a figure, so a method keeps its look in every figure of a run and a reader learns
//! the key once:
//!
//! - **colour and dash by family** (`registry::Card::family`: HPR's kernels are the families
//!   `hpr-linear`, `hpr-exp`, ...; an LOD method is its own family; the hull implementations
//!   are `hull-NAME`). The colours are Paul Tol's *muted* qualitative scheme (nine colours
//!   chosen to stay apart under the common colour-vision deficiencies,
//!   <https://personal.sron.nl/~pault/#sec:qualitative>) plus black; the grey of that scheme
//!   is kept for context. Families beyond ten in one domain share a colour and differ by dash.
//!   A peer (another project's tool, `peer_of`) takes the colour of the family of ours it
//!   pairs with, a dash of its own and a **hollow** marker. The domains (visibility, LOD,
//!   hulls) never share a figure and reuse colours.
//! - **marker by variant**: `settings` (a cloud of every setting) a circle, `best` a square,
//!   `auto` a triangle, `default` a diamond, a level-of-detail distance `×k` by k, ...;
//!   variants ranked over a run (the values of a parameter, [`ordinal`]) by their rank.
//! - families outside the table (a user's own method) take a colour and a broken dash by a
//!   hash of the name, the same in every figure; two that meet in one figure are kept apart
//!   there by the figure's shade ladder, like two variants of one family.
//!
//! [`CONTEXT`] is the thin grey of series drawn as context for the others (the other families
//! in small multiples), outside the distinct-style rule.

use serde::Serialize;

/// Paul Tol's muted qualitative scheme, then black (sRGB).
pub const PALETTE: [[u8; 3]; 10] = [
    [0x33, 0x22, 0x88], // indigo
    [0x88, 0xcc, 0xee], // cyan
    [0x44, 0xaa, 0x99], // teal
    [0x11, 0x77, 0x33], // green
    [0x99, 0x99, 0x33], // olive
    [0xdd, 0xcc, 0x77], // sand
    [0xcc, 0x66, 0x77], // rose
    [0x88, 0x22, 0x55], // wine
    [0xaa, 0x44, 0x99], // purple
    [0x00, 0x00, 0x00], // black
];

/// The colour of a Pareto front (Tol's vibrant orange): outside [`PALETTE`], so a front is
/// never taken for a method.
pub const FRONT_COLOR: [u8; 3] = [0xee, 0x77, 0x33];

/// The colour of context series (Tol's muted pale grey, darkened to show on white).
pub const CONTEXT_COLOR: [u8; 3] = [0xbb, 0xbb, 0xbb];

/// The variant of a series whose method failed its exactness claim (wrong answers): drawn in
/// [`WRONG_COLOR`], hollow and dotted in every figure, whatever its family, so that it is never
/// read as one of the ranked methods.
pub const WRONG: &str = "wrong answers";

/// The colour of wrong answers (a mid grey, darker than [`CONTEXT_COLOR`]): outside
/// [`PALETTE`].
pub const WRONG_COLOR: [u8; 3] = [0x77, 0x77, 0x77];

/// A marker's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Marker {
    /// Circle.
    Circle,
    /// Square.
    Square,
    /// Triangle pointing up.
    Triangle,
    /// Triangle pointing down.
    TriangleDown,
    /// Diamond.
    Diamond,
    /// Pentagon.
    Pentagon,
    /// Hexagon.
    Hexagon,
    /// Five-pointed star.
    Star,
    /// A large ring (the Pareto front's points).
    Ring,
    /// A small dot (context series).
    Dot,
}

/// The markers ranked variants take, in rank order.
pub const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Pentagon,
    Marker::Hexagon,
    Marker::Star,
];

impl Marker {
    /// The outline as a polygon around (0, 0), radius about 1, y pointing down (screen
    /// coordinates); the PNG and the pages draw these same vertices scaled.
    pub fn polygon(self) -> Vec<[f64; 2]> {
        let regular = |n: usize, r: f64, turn: f64| -> Vec<[f64; 2]> {
            (0..n)
                .map(|k| {
                    let a = turn + std::f64::consts::TAU * k as f64 / n as f64;
                    [r * a.cos(), r * a.sin()]
                })
                .collect()
        };
        let up = -std::f64::consts::FRAC_PI_2;
        match self {
            Marker::Circle => regular(20, 1.0, 0.0),
            Marker::Ring => regular(24, 1.6, 0.0),
            Marker::Dot => regular(12, 0.55, 0.0),
            Marker::Square => vec![[-0.85, -0.85], [0.85, -0.85], [0.85, 0.85], [-0.85, 0.85]],
            Marker::Triangle => regular(3, 1.25, up),
            Marker::TriangleDown => regular(3, 1.25, -up),
            Marker::Diamond => vec![[0.0, -1.25], [0.9, 0.0], [0.0, 1.25], [-0.9, 0.0]],
            Marker::Pentagon => regular(5, 1.1, up),
            Marker::Hexagon => regular(6, 1.08, 0.0),
            Marker::Star => (0..10)
                .map(|k| {
                    let r = if k % 2 == 0 { 1.3 } else { 0.55 };
                    let a = up + std::f64::consts::PI * k as f64 / 5.0;
                    [r * a.cos(), r * a.sin()]
                })
                .collect(),
        }
    }

    /// Every marker, for the pages' shape table.
    pub const ALL: [Marker; 10] = [
        Marker::Circle,
        Marker::Square,
        Marker::Triangle,
        Marker::TriangleDown,
        Marker::Diamond,
        Marker::Pentagon,
        Marker::Hexagon,
        Marker::Star,
        Marker::Ring,
        Marker::Dot,
    ];

    /// The name in the figures' JSON.
    pub fn name(self) -> &'static str {
        match self {
            Marker::Circle => "circle",
            Marker::Square => "square",
            Marker::Triangle => "triangle",
            Marker::TriangleDown => "triangle-down",
            Marker::Diamond => "diamond",
            Marker::Pentagon => "pentagon",
            Marker::Hexagon => "hexagon",
            Marker::Star => "star",
            Marker::Ring => "ring",
            Marker::Dot => "dot",
        }
    }
}

/// A line's dash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Dash {
    /// Unbroken.
    Solid,
    /// Dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Dash, dot (families outside the table).
    DashDot,
}

impl Dash {
    /// On and off lengths in pixels, repeated (empty: solid); SVG's `stroke-dasharray`.
    pub fn pattern(self) -> &'static [f64] {
        match self {
            Dash::Solid => &[],
            Dash::Dashed => &[8.0, 4.0],
            Dash::Dotted => &[2.0, 3.0],
            Dash::DashDot => &[8.0, 3.0, 2.0, 3.0],
        }
    }
}

/// How one series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Style {
    /// sRGB colour.
    pub color: [u8; 3],
    /// Marker shape.
    pub marker: Marker,
    /// Hollow marker (a peer), else filled.
    pub hollow: bool,
    /// Line dash.
    pub dash: Dash,
}

/// The style of context series.
pub const CONTEXT: Style = Style {
    color: CONTEXT_COLOR,
    marker: Marker::Dot,
    hollow: false,
    dash: Dash::Solid,
};

impl Style {
    /// `#rrggbb`.
    pub fn hex(&self) -> String {
        hex(self.color)
    }
}

/// `#rrggbb` of a colour.
pub fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

impl Serialize for Style {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("Style", 5)?;
        st.serialize_field("color", &self.hex())?;
        st.serialize_field("marker", self.marker.name())?;
        st.serialize_field("fill", if self.hollow { "hollow" } else { "filled" })?;
        st.serialize_field("dash", &self.dash)?;
        st.serialize_field("dasharray", self.dash.pattern())?;
        st.end()
    }
}

/// A shade of a palette colour: the colour itself, or mixed towards white or black. A peer
/// takes a lighter shade of its partner's colour (a deeper one where that colour is light),
/// and a second family on one colour a darker one, so that no two families of a domain share
/// a colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shade {
    /// The palette colour.
    Base,
    /// 35 % towards white.
    Light,
    /// 60 % towards white.
    Lighter,
    /// 40 % towards black.
    Dark,
    /// 20 % towards black (a peer of a light colour, whose tint would wash out).
    Deep,
}

impl Shade {
    /// `c` in this shade.
    pub fn of(self, c: [u8; 3]) -> [u8; 3] {
        match self {
            Base => c,
            Light => mix(c, [255; 3], 0.35),
            Lighter => mix(c, [255; 3], 0.6),
            Dark => mix(c, [0; 3], 0.4),
            Deep => mix(c, [0; 3], 0.2),
        }
    }
}

/// `a` moved the share `t` of the way to `b`.
pub fn mix(a: [u8; 3], b: [u8; 3], t: f64) -> [u8; 3] {
    let m = |x: u8, y: u8| (f64::from(x) + (f64::from(y) - f64::from(x)) * t).round() as u8;
    [m(a[0], b[0]), m(a[1], b[1]), m(a[2], b[2])]
}

/// One row of the table: family, palette index, shade, dash, peer.
type Entry = (&'static str, usize, Shade, Dash, bool);

use Shade::{Base, Dark, Deep, Light, Lighter};

/// The families the table knows. A peer's colour is a lighter shade of its partner's (a darker
/// one where the partner's colour is light).
const TABLE: &[Entry] = &[
    // Visibility, ours.
    ("hpr-linear", 0, Base, Dash::Solid, false),
    ("hpr-exp", 1, Base, Dash::Solid, false),
    ("hpr-log", 2, Base, Dash::Solid, false),
    ("hpr-expdecay", 4, Base, Dash::Solid, false),
    ("hpr-confidence", 8, Base, Dash::Solid, false),
    ("hpr-approx", 5, Base, Dash::Solid, false),
    ("robust", 7, Base, Dash::Solid, false),
    ("raycast", 3, Base, Dash::Solid, false),
    ("splat", 6, Base, Dash::Solid, false),
    ("screenspace", 9, Base, Dash::Solid, false),
    ("vardensity", 2, Dark, Dash::Dashed, false),
    ("example-zbuffer", 5, Dark, Dash::Dashed, false),
    // The learned method: a dark green of its own line (not a light shade, which washes out).
    ("neuralvis", 3, Dark, Dash::DashDot, false),
    // Visibility, peers: the partner's hue, their own shade, hollow.
    ("cgal-hpr", 0, Light, Dash::Dashed, true),
    ("open3d-hpr", 0, Lighter, Dash::Dotted, true),
    ("pcu-raycast", 3, Light, Dash::Dashed, true),
    // Rose is light already: its tint washes out on white, so this peer takes a deeper shade
    // (not `Dark`, which nears `robust`'s wine).
    ("vtk-zbuffer", 6, Deep, Dash::Dashed, true),
    ("pcl-voxel", 8, Light, Dash::Dashed, true),
    // The ground truths.
    ("reference", 1, Dark, Dash::Dotted, false),
    ("zbuffer", 4, Dark, Dash::Dotted, false),
    ("exact", 7, Light, Dash::Dotted, false),
    // The Pareto front of a figure (its colour is [`FRONT_COLOR`], its marker a ring).
    ("pareto-front", 9, Base, Dash::Solid, false),
    // Hull implementations (HPR's hull; the `hull` and `scale` experiments).
    ("hull-own", 0, Base, Dash::Solid, false),
    ("hull-qhull", 3, Base, Dash::Solid, false),
    ("hull-qhull-qj", 2, Base, Dash::Solid, false),
    ("hull-parry", 6, Base, Dash::Solid, false),
    ("hull-quickhull", 5, Base, Dash::Solid, false),
    ("hull-chull", 7, Base, Dash::Solid, false),
    ("hull-cgal", 1, Base, Dash::Dashed, true),
    // Level of detail.
    ("qsplat", 0, Base, Dash::Solid, false),
    ("spt", 6, Base, Dash::Solid, false),
    ("srn", 3, Base, Dash::Solid, false),
    ("random", 9, Base, Dash::Solid, false),
    ("full", 4, Base, Dash::Dotted, false),
    ("py3dtiles-lod", 1, Base, Dash::Dashed, true),
    ("copc-lod", 2, Base, Dash::DashDot, true),
];

/// The shades a series takes, in order, when its colour is already another series' in its
/// figure (two variants of one family in one panel, say): its own colour first.
const LADDER: [(Shade, f64); 10] = [
    (Base, 0.0),
    (Dark, 0.0),
    (Light, 0.0),
    (Lighter, 0.0),
    (Dark, 0.6),
    (Light, 0.8),
    (Dark, 0.2),
    (Light, 0.2),
    (Light, 0.5),
    (Dark, 0.75),
];

/// Colours no method takes: the front, the context, wrong answers.
const RESERVED: [[u8; 3]; 3] = [FRONT_COLOR, CONTEXT_COLOR, WRONG_COLOR];

/// The first colour of `base`'s shades that lies at least a small distance from every colour
/// in `taken` and the reserved ones; `None` when every shade is too near.
pub fn free_shade(base: [u8; 3], taken: &[[u8; 3]]) -> Option<[u8; 3]> {
    let near = |a: [u8; 3], b: [u8; 3]| {
        let d: f64 = (0..3)
            .map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2))
            .sum();
        d.sqrt() < 30.0
    };
    shades(base)
        .into_iter()
        .find(|c| !taken.iter().chain(&RESERVED).any(|t| near(*t, *c)))
}

/// The shades of `base` a series may take, in the order [`free_shade`] tries them: `base`
/// itself first. A method's series are drawn in these colours only, in every figure.
pub fn shades(base: [u8; 3]) -> Vec<[u8; 3]> {
    LADDER
        .iter()
        .map(|&(shade, extra)| {
            let c = shade.of(base);
            match (shade, extra) {
                (_, 0.0) => c,
                (Dark, t) => mix(base, [0; 3], t),
                (_, t) => mix(base, [255; 3], t),
            }
        })
        .collect()
}

/// The marker of a named variant; `None` for a variant the table does not name.
fn named_marker(variant: &str) -> Option<Marker> {
    let v = variant.trim();
    let v = v.strip_prefix("distance ").unwrap_or(v);
    Some(match v {
        "" | "settings" | "select" | "synchronous" => Marker::Circle,
        "best" | "build" => Marker::Square,
        "auto" => Marker::Triangle,
        "default" => Marker::Diamond,
        "build-ooc" | "background" => Marker::TriangleDown,
        _ => {
            // A distance multiple `×k`: ×1 a circle, ×2 a downward triangle, then by log2 k.
            let k: f64 = v.strip_prefix('×')?.parse().ok()?;
            match k {
                k if k <= 1.0 => Marker::Circle,
                k if k <= 2.0 => Marker::TriangleDown,
                k if k <= 4.0 => Marker::Pentagon,
                k if k <= 8.0 => Marker::Hexagon,
                _ => Marker::Star,
            }
        }
    })
}

/// FNV-1a of a name: a stable slot for names no table holds.
fn hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The colour, dash and peer flag of a family.
fn family_slot(family: &str) -> ([u8; 3], Dash, bool) {
    if let Some(&(_, c, shade, dash, peer)) = TABLE.iter().find(|e| e.0 == family) {
        return (shade.of(PALETTE[c]), dash, peer);
    }
    // Outside the table (a user's external method): a slot by the name alone, so that the
    // family looks the same in every figure of every run; two such families that meet in
    // one figure are kept apart there by the figure's shade ladder.
    let h = hash(family);
    let dash = [Dash::DashDot, Dash::Dashed, Dash::Dotted][(h / 10 % 3) as usize];
    (PALETTE[(h % 10) as usize], dash, false)
}

/// The style of `variant` of `family`: colour and dash by family, marker by variant, hollow
/// for a peer. A variant the table does not name takes a marker by a hash of its name: use
/// [`ordinal`] for variants that are the values of a parameter.
pub fn style(family: &str, variant: &str) -> Style {
    if variant == WRONG {
        // Two wrong methods in one panel still differ by marker (and by their labels).
        return Style {
            color: WRONG_COLOR,
            marker: MARKERS[(hash(family) % MARKERS.len() as u64) as usize],
            hollow: true,
            dash: Dash::Dotted,
        };
    }
    let (mut color, dash, hollow) = family_slot(family);
    let marker = if family == "pareto-front" {
        color = FRONT_COLOR;
        Marker::Ring
    } else {
        named_marker(variant).unwrap_or(MARKERS[(hash(variant) % MARKERS.len() as u64) as usize])
    };
    Style {
        color,
        marker,
        hollow,
        dash,
    }
}

/// The style of the variant of `family` ranked `rank` among its kind over a run (the values of
/// a parameter, sorted): the family's colour, the rank's marker and dash, so that up to 24
/// ranked variants of one family stay apart.
pub fn ordinal(family: &str, rank: usize) -> Style {
    let (color, _, hollow) = family_slot(family);
    const DASHES: [Dash; 3] = [Dash::Solid, Dash::Dashed, Dash::Dotted];
    Style {
        color,
        marker: MARKERS[rank % MARKERS.len()],
        hollow,
        dash: DASHES[(rank / MARKERS.len()) % DASHES.len()],
    }
}

/// The family of `method` at the setting labelled `setting` (`k=v` pairs joined by `;`):
/// `registry::Method::family` for a visibility method of `catalogue`, the name for an LOD
/// method or a name the catalogue does not know (results of a method no longer in it).
pub fn family(catalogue: &registry::Catalogue, method: &str, setting: &str) -> String {
    match catalogue.card_named(method) {
        Some(m) => m.family(&registry::Setting::parse(setting)),
        None => method.to_owned(),
    }
}

/// True when `family` is a peer's (a hollow marker).
pub fn is_peer(family: &str) -> bool {
    family_slot(family).2
}

/// Every marker's polygon by name, for the pages (which draw the same shapes).
pub fn marker_shapes() -> serde_json::Value {
    serde_json::Value::Object(
        Marker::ALL
            .iter()
            .map(|m| (m.name().to_owned(), serde_json::json!(m.polygon())))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;

    #[test]
    fn the_table_gives_each_family_of_a_domain_its_own_colour_and_dash() {
        // Families that share figures: the visibility methods with the ground truths, the LOD
        // methods, the hulls.
        let domains: [&[&str]; 3] = [
            &[
                "hpr-linear",
                "hpr-exp",
                "hpr-log",
                "hpr-expdecay",
                "hpr-confidence",
                "hpr-approx",
                "robust",
                "raycast",
                "splat",
                "screenspace",
                "vardensity",
                "example-zbuffer",
                "cgal-hpr",
                "open3d-hpr",
                "pcu-raycast",
                "vtk-zbuffer",
                "pcl-voxel",
                "reference",
                "zbuffer",
                "exact",
            ],
            &[
                "qsplat",
                "spt",
                "srn",
                "random",
                "full",
                "py3dtiles-lod",
                "copc-lod",
            ],
            &[
                "hull-own",
                "hull-qhull",
                "hull-qhull-qj",
                "hull-parry",
                "hull-quickhull",
                "hull-chull",
                "hull-cgal",
            ],
        ];
        for domain in domains {
            let slots: BTreeSet<_> = domain
                .iter()
                .map(|f| {
                    let s = style(f, "best");
                    (s.color, s.dash, s.hollow)
                })
                .collect();
            assert_eq!(slots.len(), domain.len(), "{domain:?}");
            // Within a domain no two families share a colour (a peer is its own shade).
            let colours: BTreeSet<_> = domain.iter().map(|f| style(f, "best").color).collect();
            assert_eq!(colours.len(), domain.len(), "{domain:?}");
        }
        // Every table row is unique by name.
        let names: BTreeSet<_> = TABLE.iter().map(|e| e.0).collect();
        assert_eq!(names.len(), TABLE.len());
    }

    #[test]
    fn wrong_answers_are_grey_hollow_and_dotted_whatever_the_family() {
        for family in ["hull-quickhull", "hull-own", "open3d-hpr", "hpr-linear"] {
            let s = style(family, WRONG);
            assert_eq!(
                (s.color, s.hollow, s.dash),
                (WRONG_COLOR, true, Dash::Dotted)
            );
            assert_ne!(style(family, "").color, WRONG_COLOR, "{family}");
        }
        assert!(!PALETTE.contains(&WRONG_COLOR) && WRONG_COLOR != CONTEXT_COLOR);
    }

    #[test]
    fn a_pareto_front_has_a_colour_no_method_has() {
        let front = style("pareto-front", "");
        assert_eq!(front.color, FRONT_COLOR);
        assert!(!PALETTE.contains(&front.color));
        assert!(!PALETTE.contains(&CONTEXT_COLOR));
        for card in registry::Catalogue::builtin().cards() {
            let family = card.family(&card.default_setting());
            assert_ne!(style(&family, "best").color, front.color, "{family}");
        }
    }

    #[test]
    fn peers_are_hollow_in_a_shade_of_their_partners_colour() {
        assert!(style("cgal-hpr", "best").hollow);
        assert!(!style("hpr-linear", "best").hollow);
        let (ours, peer) = (
            style("hpr-linear", "best").color,
            style("cgal-hpr", "best").color,
        );
        assert_ne!(ours, peer);
        assert_eq!(peer, mix(ours, [255; 3], 0.35));
        assert_eq!(
            style("vtk-zbuffer", "").color,
            Deep.of(style("splat", "").color)
        );
    }

    #[test]
    fn a_free_shade_stays_clear_of_the_taken_and_reserved_colours() {
        let indigo = PALETTE[0];
        assert_eq!(free_shade(indigo, &[]), Some(indigo));
        let second = free_shade(indigo, &[indigo]).unwrap();
        assert_ne!(second, indigo);
        let third = free_shade(indigo, &[indigo, second]).unwrap();
        assert!(![indigo, second].contains(&third));
        // Black's lighter shades stop short of the wrong answers' grey.
        let c = free_shade([0; 3], &[[0; 3]]).unwrap();
        assert_ne!(c, WRONG_COLOR);
        assert_ne!(c, [0; 3]);
    }

    #[test]
    fn variants_differ_by_marker_and_the_style_is_a_function_of_its_arguments() {
        let markers: BTreeSet<_> = ["settings", "best", "auto", "default"]
            .iter()
            .map(|v| style("raycast", v).marker)
            .collect();
        assert_eq!(markers.len(), 4);
        assert_ne!(
            style("qsplat", "distance ×1"),
            style("qsplat", "distance ×2")
        );
        assert_eq!(style("qsplat", "×2"), style("qsplat", "distance ×2"));
        assert_eq!(style("hpr-exp", "auto"), style("hpr-exp", "auto"));
        let ranked: BTreeSet<_> = (0..24).map(|r| ordinal("splat", r)).collect();
        assert_eq!(ranked.len(), 24);
    }

    #[test]
    fn every_built_in_method_has_its_row() {
        // A built-in family left to the name's slot could share a colour and dash with one
        // in the table (neuralvis's did: hpr-log's teal).
        for card in registry::BUILT_IN {
            let family = card.family(&card.default_setting());
            assert!(TABLE.iter().any(|e| e.0 == family), "{family} has no row");
        }
    }

    #[test]
    fn families_outside_the_table_take_the_dash_dot_slots() {
        let s = style("somebody-elses-method", "best");
        assert!(s.dash != Dash::Solid);
        assert_eq!(s, style("somebody-elses-method", "best"));
    }

    #[test]
    fn marker_polygons_are_closed_shapes_about_the_origin() {
        for m in Marker::ALL {
            let p = m.polygon();
            assert!(p.len() >= 3, "{m:?}");
            let r = p
                .iter()
                .map(|[x, y]| (x * x + y * y).sqrt())
                .fold(0.0, f64::max);
            assert!((0.5..=1.7).contains(&r), "{m:?}: {r}");
        }
    }
}
