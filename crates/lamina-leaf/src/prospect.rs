//! PROSPECT-D and PROSPECT-PRO: a leaf's directional-hemispherical reflectance and
//! transmittance, 400-2500 nm, from its structure and pigments.
//!
//! The model (Jacquemoud & Baret 1990; Féret et al. 2017, *Remote Sensing of Environment*
//! 193:204-215 for PROSPECT-D; Féret et al. 2021, *RSE* 252:112173 for PROSPECT-PRO) is a pile
//! of `N` absorbing plates (`N` need not be an integer):
//!
//! 1. The absorption of one elementary plate at wavelength `λ` is
//!    `k(λ) = Σ_i C_i K_i(λ) / N`, the pigment contents `C_i` (per leaf area) times their
//!    specific absorption coefficients `K_i` (the embedded table), shared among `N` plates.
//! 2. Its transmissivity for isotropic light is `τ = (1 - k) e^{-k} + k² E₁(k)`
//!    (`E₁` the exponential integral).
//! 3. Its faces are dielectric borders of refractive index `n(λ)`; their transmissivity for
//!    light within a cone of half-angle `α` is Stern's (1964) closed form `t_av(α, n)`
//!    (Allen 1973). The top face of the leaf is lit within `α = 40°` (PROSPECT's choice for an
//!    integrating sphere's near-normal beam plus the leaf's surface roughness), every inner face
//!    isotropically (`α = 90°`).
//! 4. One plate's `R`, `T` follow from the multiple reflections between its faces (Allen et
//!    al. 1969), and `N - 1` more plates are added with Stokes' (1862) closed form for a pile
//!    of plates, which holds for real `N`.
//!
//! The constants are J.-B. Féret's PROSPECT-PRO table (`data/prospect/`, MIT licence,
//! `LICENSE.md` there), embedded losslessly; PROSPECT-D uses the same table without the protein
//! and carbon-based-constituent columns (PROSPECT-D's dry matter `cm` is their sum in PRO).
//! `tests/prospect.rs` compares this code with an independent implementation (the `prosail`
//! Python package) at every wavelength.
//!
//! Everything is computed in `f64` on the model's own grid, 400-2500 nm at 1 nm.

use crate::LeafError;
use std::sync::OnceLock;

/// First wavelength of PROSPECT's grid, nm.
pub const PROSPECT_START_NM: u32 = 400;
/// Last wavelength of PROSPECT's grid, nm (inclusive).
pub const PROSPECT_END_NM: u32 = 2500;
/// Number of wavelengths on the grid (1 nm steps).
pub const PROSPECT_LEN: usize = (PROSPECT_END_NM - PROSPECT_START_NM + 1) as usize;

/// Which PROSPECT: they differ only in how dry matter is described.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ProspectModel {
    /// PROSPECT-D (2017): dry matter as one content `cm` (leaf mass per area).
    #[default]
    D,
    /// PROSPECT-PRO (2021): dry matter split into proteins `prot` and carbon-based
    /// constituents `cbc` (`cm = prot + cbc`), which remote sensing of nitrogen needs.
    Pro,
}

impl std::fmt::Display for ProspectModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ProspectModel::D => "PROSPECT-D",
            ProspectModel::Pro => "PROSPECT-PRO",
        })
    }
}

/// PROSPECT's inputs as a user gives them (a command's flags, a Python call's keywords):
/// each optional, the model named. [`PigmentInputs::resolve`] fills in the rest and checks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PigmentInputs {
    /// Which model the user asked for.
    pub model: ProspectModel,
    /// [`Pigments::n`].
    pub n: Option<f64>,
    /// [`Pigments::cab`], µg/cm².
    pub cab: Option<f64>,
    /// [`Pigments::car`], µg/cm².
    pub car: Option<f64>,
    /// [`Pigments::anth`], µg/cm².
    pub anth: Option<f64>,
    /// [`Pigments::cbrown`], arbitrary units.
    pub cbrown: Option<f64>,
    /// [`Pigments::cw`], cm.
    pub cw: Option<f64>,
    /// [`Pigments::cm`], g/cm² (PROSPECT-D only).
    pub cm: Option<f64>,
    /// [`Pigments::prot`], g/cm² (PROSPECT-PRO only; default 0.0012).
    pub prot: Option<f64>,
    /// [`Pigments::cbc`], g/cm² (PROSPECT-PRO only; default 0.0078).
    pub cbc: Option<f64>,
    /// [`Pigments::alpha`], degrees.
    pub alpha: Option<f64>,
}

impl PigmentInputs {
    /// The pigments: missing inputs take [`Pigments::default`]'s values (PROSPECT-PRO's
    /// `prot` 0.0012 and `cbc` 0.0078 g/cm², with `cm` 0), checked against their published
    /// ranges. Refused: PRO's inputs with model D, `cm` with PRO, PRO with no dry matter.
    /// `prefix` goes before input names in errors (`"--"` for flags, `""` for keywords) and
    /// `pro_hint` says how to ask for PROSPECT-PRO (`"--model pro"`, `"model='pro'"`).
    pub fn resolve(&self, prefix: &str, pro_hint: &str) -> Result<Pigments, LeafError> {
        let d = Pigments::default();
        let refuse = |name: &str, v: f64, why: String| LeafError::InvalidPigment {
            field: format!("{prefix}{name}"),
            value: format!("{v}"),
            allowed: why,
        };
        let mut p = Pigments {
            n: self.n.unwrap_or(d.n),
            cab: self.cab.unwrap_or(d.cab),
            car: self.car.unwrap_or(d.car),
            anth: self.anth.unwrap_or(d.anth),
            cbrown: self.cbrown.unwrap_or(d.cbrown),
            cw: self.cw.unwrap_or(d.cw),
            cm: self.cm.unwrap_or(d.cm),
            prot: 0.0,
            cbc: 0.0,
            alpha: self.alpha.unwrap_or(d.alpha),
        };
        match self.model {
            ProspectModel::D => {
                for (name, v) in [("prot", self.prot), ("cbc", self.cbc)] {
                    if let Some(v) = v {
                        return Err(refuse(
                            name,
                            v,
                            format!(
                                "a PROSPECT-PRO input: ask for {pro_hint} (and drop {prefix}cm)"
                            ),
                        ));
                    }
                }
            }
            ProspectModel::Pro => {
                if let Some(cm) = self.cm {
                    return Err(refuse(
                        "cm",
                        cm,
                        format!(
                            "PROSPECT-D's dry matter; PROSPECT-PRO splits it into {prefix}prot \
                             and {prefix}cbc (cm = prot + cbc)"
                        ),
                    ));
                }
                p.cm = 0.0;
                p.prot = self.prot.unwrap_or(0.0012);
                p.cbc = self.cbc.unwrap_or(0.0078);
                if p.prot == 0.0 && p.cbc == 0.0 {
                    return Err(refuse(
                        "prot",
                        0.0,
                        format!(
                            "PROSPECT-PRO needs {prefix}prot or {prefix}cbc above 0 (they are its dry matter)"
                        ),
                    ));
                }
            }
        }
        p.validate(prefix)?;
        Ok(p)
    }
}

/// A leaf's structure and biochemistry, the inputs of PROSPECT. Contents are per unit of
/// (one-sided) leaf area. The model is implied: `prot` or `cbc` non-zero makes it
/// PROSPECT-PRO, which then needs `cm = 0` (see [`Pigments::validate`]).
///
/// In a `leaf.toml` or scene file (`pigments = { n = 1.8, cab = 45 }`) every key is optional:
/// a missing one takes [`Pigments::default`]'s value, except that `cm` defaults to 0 where
/// `prot` or `cbc` is given (PROSPECT-PRO). Unknown keys are errors.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(from = "PigmentKeys")]
pub struct Pigments {
    /// Leaf structure parameter: the number of elementary plates (1 = compact monocot,
    /// 1.5-2.5 = dicots with more intercellular air). Dimensionless, real.
    pub n: f64,
    /// Chlorophyll a + b, µg/cm².
    pub cab: f64,
    /// Carotenoids, µg/cm².
    pub car: f64,
    /// Anthocyanins, µg/cm².
    pub anth: f64,
    /// Brown pigments (senescence), arbitrary units (0 for a green leaf, about 1 for brown).
    pub cbrown: f64,
    /// Equivalent water thickness, cm (= g/cm² of water).
    pub cw: f64,
    /// Dry matter content (leaf mass per area), g/cm². PROSPECT-D only.
    pub cm: f64,
    /// Proteins, g/cm². PROSPECT-PRO only.
    pub prot: f64,
    /// Carbon-based constituents (cellulose, lignin, sugars...), g/cm². PROSPECT-PRO only.
    pub cbc: f64,
    /// Not a pigment: PROSPECT's surface parameter, the half-angle (degrees) of the cone of
    /// incidence for which the leaf's top face is averaged (Stern's `t_av(α, n)`). 40° is
    /// the model's standard (a near-normal beam plus the surface's roughness); a larger `α`
    /// reflects more at the surface, as hairy or waxy leaves do in an integrating sphere.
    /// `lamina leaf fit` fits it.
    pub alpha: f64,
}

/// [`Pigments`] as written in a file: every key optional.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PigmentKeys {
    n: Option<f64>,
    cab: Option<f64>,
    car: Option<f64>,
    anth: Option<f64>,
    cbrown: Option<f64>,
    cw: Option<f64>,
    cm: Option<f64>,
    prot: Option<f64>,
    cbc: Option<f64>,
    alpha: Option<f64>,
}

impl From<PigmentKeys> for Pigments {
    fn from(k: PigmentKeys) -> Self {
        let d = Pigments::default();
        let pro = k.prot.is_some() || k.cbc.is_some();
        Pigments {
            n: k.n.unwrap_or(d.n),
            cab: k.cab.unwrap_or(d.cab),
            car: k.car.unwrap_or(d.car),
            anth: k.anth.unwrap_or(d.anth),
            cbrown: k.cbrown.unwrap_or(d.cbrown),
            cw: k.cw.unwrap_or(d.cw),
            cm: k.cm.unwrap_or(if pro { 0.0 } else { d.cm }),
            prot: k.prot.unwrap_or(0.0),
            cbc: k.cbc.unwrap_or(0.0),
            alpha: k.alpha.unwrap_or(d.alpha),
        }
    }
}

impl Default for Pigments {
    /// A typical mature green dicot leaf (close to the ANGERS data set's medians):
    /// N 1.5, Cab 40, Car 8, no anthocyanins or brown pigments, Cw 0.012 cm, Cm 0.009 g/cm².
    fn default() -> Self {
        Pigments {
            n: 1.5,
            cab: 40.0,
            car: 8.0,
            anth: 0.0,
            cbrown: 0.0,
            cw: 0.012,
            cm: 0.009,
            prot: 0.0,
            cbc: 0.0,
            alpha: 40.0,
        }
    }
}

/// One input's published range: (`leaf.toml` / CLI name, low, high, unit).
type Range = (&'static str, f64, f64, &'static str);

/// The ranges each input is accepted in. They are the ranges of the data sets PROSPECT-D and
/// -PRO were calibrated and validated on (ANGERS, LOPEX93 and the PRO data sets; Féret et
/// al. 2017 table 2, 2021 table 1), widened by about a third, and the usual bounds of PROSPECT
/// inversions. Outside them the specific absorption coefficients were never tested. `alpha`
/// (last) is the surface parameter, 10-90°.
pub const PIGMENT_RANGES: [Range; 10] = [
    ("n", 1.0, 3.5, "plates"),
    ("cab", 0.0, 120.0, "µg/cm²"),
    ("car", 0.0, 40.0, "µg/cm²"),
    ("anth", 0.0, 40.0, "µg/cm²"),
    ("cbrown", 0.0, 2.0, "arbitrary units"),
    ("cw", 0.0, 0.1, "cm"),
    ("cm", 0.0, 0.05, "g/cm²"),
    ("prot", 0.0, 0.01, "g/cm²"),
    ("cbc", 0.0, 0.05, "g/cm²"),
    ("alpha", 10.0, 90.0, "degrees"),
];

impl Pigments {
    /// The ten inputs in [`PIGMENT_RANGES`] order.
    pub fn values(&self) -> [f64; 10] {
        [
            self.n,
            self.cab,
            self.car,
            self.anth,
            self.cbrown,
            self.cw,
            self.cm,
            self.prot,
            self.cbc,
            self.alpha,
        ]
    }

    /// Builds pigments from the ten inputs in [`PIGMENT_RANGES`] order.
    pub fn from_values(v: [f64; 10]) -> Self {
        Pigments {
            n: v[0],
            cab: v[1],
            car: v[2],
            anth: v[3],
            cbrown: v[4],
            cw: v[5],
            cm: v[6],
            prot: v[7],
            cbc: v[8],
            alpha: v[9],
        }
    }

    /// The model these pigments are for: PRO when proteins or carbon-based constituents are
    /// given, else D.
    pub fn model(&self) -> ProspectModel {
        if self.prot != 0.0 || self.cbc != 0.0 {
            ProspectModel::Pro
        } else {
            ProspectModel::D
        }
    }

    /// Checks every input against its published range ([`PIGMENT_RANGES`]) and that D and
    /// PRO's dry matter are not mixed. `prefix` goes before the field name in the error
    /// (e.g. `"pigments."` for a `leaf.toml`, `"--"` for the command line).
    pub fn validate(&self, prefix: &str) -> Result<(), LeafError> {
        for ((name, lo, hi, unit), v) in PIGMENT_RANGES.iter().zip(self.values()) {
            if !(v.is_finite() && v >= *lo && v <= *hi) {
                return Err(LeafError::InvalidPigment {
                    field: format!("{prefix}{name}"),
                    value: format!("{v}"),
                    allowed: format!(
                        "must be a finite number in [{lo}, {hi}] {unit} (the range PROSPECT \
                         was calibrated over)"
                    ),
                });
            }
        }
        if self.model() == ProspectModel::Pro && self.cm != 0.0 {
            return Err(LeafError::InvalidPigment {
                field: format!("{prefix}cm"),
                value: format!("{}", self.cm),
                allowed: "PROSPECT-PRO describes dry matter by prot + cbc: cm must be 0 when \
                          prot or cbc is given"
                    .into(),
            });
        }
        Ok(())
    }

    /// The absorption coefficient `k` of one elementary plate at grid index `i`
    /// (wavelength `400 + i` nm): `Σ C_j K_j / N`, dimensionless.
    pub fn plate_absorption(&self, i: usize) -> f64 {
        let c = &constants()[i];
        (self.cab * c.k_cab
            + self.car * c.k_car
            + self.anth * c.k_anth
            + self.cbrown * c.k_brown
            + self.cw * c.k_w
            + self.cm * c.k_m
            + self.prot * c.k_prot
            + self.cbc * c.k_cbc)
            / self.n
    }
}

/// PROSPECT's optical constants at one wavelength (units as the contents that multiply them).
#[derive(Clone, Copy, Debug)]
pub struct OpticalConstants {
    /// Refractive index of the leaf's plates.
    pub nr: f64,
    /// Chlorophyll a+b, cm²/µg.
    pub k_cab: f64,
    /// Carotenoids, cm²/µg.
    pub k_car: f64,
    /// Anthocyanins, cm²/µg.
    pub k_anth: f64,
    /// Brown pigments, per arbitrary unit.
    pub k_brown: f64,
    /// Water, 1/cm.
    pub k_w: f64,
    /// Dry matter, cm²/g.
    pub k_m: f64,
    /// Proteins, cm²/g.
    pub k_prot: f64,
    /// Carbon-based constituents, cm²/g.
    pub k_cbc: f64,
}

/// The embedded PROSPECT-PRO table, parsed once: 2101 rows, 400-2500 nm.
pub fn constants() -> &'static [OpticalConstants; PROSPECT_LEN] {
    static TABLE: OnceLock<Box<[OpticalConstants; PROSPECT_LEN]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let text = include_str!("../data/prospect/prospect_pro.tsv");
        let rows: Vec<OpticalConstants> = text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .map(|l| {
                let v: Vec<f64> = l
                    .split_ascii_whitespace()
                    .map(|c| c.parse().expect("embedded PROSPECT table is numeric"))
                    .collect();
                assert_eq!(v.len(), 9, "embedded PROSPECT table has 9 columns");
                OpticalConstants {
                    nr: v[0],
                    k_cab: v[1],
                    k_car: v[2],
                    k_anth: v[3],
                    k_brown: v[4],
                    k_w: v[5],
                    k_m: v[6],
                    k_prot: v[7],
                    k_cbc: v[8],
                }
            })
            .collect();
        rows.try_into()
            .map(Box::new)
            .unwrap_or_else(|v: Vec<_>| panic!("embedded PROSPECT table has {} rows", v.len()))
    })
}

/// A leaf's reflectance and transmittance on PROSPECT's grid (400-2500 nm, 1 nm), both
/// directional-hemispherical for light from the adaxial side (PROSPECT has one side).
#[derive(Clone, Debug, PartialEq)]
pub struct LeafSpectrum {
    /// Reflectance `R(400 + i nm)`, in [0, 1].
    pub r: Vec<f64>,
    /// Transmittance `T(400 + i nm)`, in [0, 1].
    pub t: Vec<f64>,
}

impl LeafSpectrum {
    /// Wavelength of grid index `i`, nm.
    pub fn wavelength(i: usize) -> f64 {
        PROSPECT_START_NM as f64 + i as f64
    }

    /// Linear interpolation of `(R, T)` at `nm` (clamped to 400-2500 nm).
    pub fn at(&self, nm: f64) -> (f64, f64) {
        let x = (nm - PROSPECT_START_NM as f64).clamp(0.0, (PROSPECT_LEN - 1) as f64);
        let i = (x.floor() as usize).min(PROSPECT_LEN - 2);
        let f = x - i as f64;
        let lerp = |v: &[f64]| v[i] + f * (v[i + 1] - v[i]);
        (lerp(&self.r), lerp(&self.t))
    }
}

/// Runs PROSPECT (D or PRO, as [`Pigments::model`] says) for `p`, which must have passed
/// [`Pigments::validate`] (unchecked inputs still give finite numbers when `n >= 1`).
pub fn prospect(p: &Pigments) -> LeafSpectrum {
    let table = constants();
    let mut r = Vec::with_capacity(PROSPECT_LEN);
    let mut t = Vec::with_capacity(PROSPECT_LEN);
    for (i, c) in table.iter().enumerate() {
        let (ri, ti) = plate_pile(p.n, c.nr, p.plate_absorption(i), p.alpha);
        r.push(ri);
        t.push(ti);
    }
    LeafSpectrum { r, t }
}

/// `(R, T)` of a pile of `n` plates of refractive index `nr`, each with absorption `k`, lit
/// within `alpha_deg` (PROSPECT: 40°) on top.
pub fn plate_pile(n: f64, nr: f64, k: f64, alpha_deg: f64) -> (f64, f64) {
    plate_pile_with(n, nr, k, stern_tav(alpha_deg, nr), stern_tav(90.0, nr))
}

/// [`plate_pile`] with the top face's transmissivity `t_alpha` and the inner faces' `t12`
/// given (they depend on the wavelength only through `nr`: a fit caches them).
pub fn plate_pile_with(n: f64, nr: f64, k: f64, t_alpha: f64, t12: f64) -> (f64, f64) {
    let tau = plate_transmissivity(k);
    // Borders: the top face lit within alpha, the inner faces isotropically; from inside, a
    // border passes t12 / n² (reciprocity of radiance across an index step).
    let r_alpha = 1.0 - t_alpha;
    let r12 = 1.0 - t12;
    let t21 = t12 / (nr * nr);
    let r21 = 1.0 - t21;

    // The first plate, seen from above (lit at alpha) and from below (isotropic).
    let bounce = 1.0 - r21 * r21 * tau * tau;
    let t_top = t_alpha * tau * t21 / bounce;
    let r_top = r_alpha + r21 * tau * t_top;
    let t_one = t12 * tau * t21 / bounce;
    let r_one = r12 + r21 * tau * t_one;

    // The other n - 1 plates, as one pile (Stokes).
    let (r_sub, t_sub) = stokes_pile(r_one, t_one, n - 1.0);

    // The first plate on top of the pile.
    let between = 1.0 - r_sub * r_one;
    (
        r_top + t_top * r_sub * t_one / between,
        t_top * t_sub / between,
    )
}

/// Stokes' closed form for a pile of `m >= 0` (real) plates each with reflectance `r` and
/// transmittance `t` for diffuse light.
fn stokes_pile(r: f64, t: f64, m: f64) -> (f64, f64) {
    if r + t >= 1.0 - 1e-12 {
        // No absorption: the pile only redistributes; T = t / (t + (1 - t) m).
        let t_m = t / (t + (1.0 - t) * m);
        return (1.0 - t_m, t_m);
    }
    let d = ((1.0 + r + t) * (1.0 + r - t) * (1.0 - r + t) * (1.0 - r - t)).sqrt();
    let a = (1.0 + r * r - t * t + d) / (2.0 * r);
    let b = (1.0 - r * r + t * t + d) / (2.0 * t);
    let b_m = b.powf(m);
    let b_2m = b_m * b_m;
    let denom = a * a * b_2m - 1.0;
    (a * (b_2m - 1.0) / denom, b_m * (a * a - 1.0) / denom)
}

/// Transmissivity of an absorbing plate of absorption (optical depth) `k` for isotropic
/// light: `(1 - k) e^{-k} + k² E₁(k)`; 1 at `k = 0`.
pub fn plate_transmissivity(k: f64) -> f64 {
    if k <= 0.0 {
        1.0
    } else {
        (1.0 - k) * (-k).exp() + k * k * exp_integral_e1(k)
    }
}

/// The exponential integral `E₁(x) = ∫_x^∞ e^{-s}/s ds` for `x > 0`, to about 1e-15
/// relative: its power series below 1, a continued fraction (modified Lentz) above.
pub fn exp_integral_e1(x: f64) -> f64 {
    const EULER_GAMMA: f64 = 0.577_215_664_901_532_9;
    debug_assert!(x > 0.0);
    if x <= 1.0 {
        // E1 = -γ - ln x - Σ_{k>=1} (-x)^k / (k k!)
        let mut sum = 0.0;
        let mut term = 1.0; // (-x)^k / k!
        for k in 1..60 {
            term *= -x / k as f64;
            let add = term / k as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        -EULER_GAMMA - x.ln() - sum
    } else {
        // e^{-x} / (x + 1 - 1/(x + 3 - 4/(x + 5 - ...))), evaluated by Lentz's method.
        let tiny = 1e-300;
        let mut b = x + 1.0;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..200 {
            let a = -((i * i) as f64);
            b += 2.0;
            d = 1.0 / (a * d + b);
            c = b + a / c;
            let delta = c * d;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        h * (-x).exp()
    }
}

/// Stern's (1964) average transmissivity of a planar dielectric border of relative index
/// `n` for isotropic light arriving within `alpha` degrees of the normal (0 < alpha <= 90),
/// both polarisations averaged. (Allen 1973 gives the same closed form.)
pub fn stern_tav(alpha_deg: f64, n: f64) -> f64 {
    let n2 = n * n;
    let np = n2 + 1.0;
    let nm = n2 - 1.0;
    let a = (n + 1.0) * (n + 1.0) / 2.0;
    let k = -(n2 - 1.0) * (n2 - 1.0) / 4.0;
    let sa = alpha_deg.to_radians().sin();
    let sa2 = if alpha_deg >= 90.0 { 1.0 } else { sa * sa };
    let b1 = if alpha_deg >= 90.0 {
        0.0
    } else {
        // Zero at 90° exactly; clamp the rounding just below it.
        ((sa2 - np / 2.0).powi(2) + k).max(0.0).sqrt()
    };
    let b2 = sa2 - np / 2.0;
    let b = b1 - b2;
    let ts = (k * k / (6.0 * b.powi(3)) + k / b - b / 2.0)
        - (k * k / (6.0 * a.powi(3)) + k / a - a / 2.0);
    let tp1 = -2.0 * n2 * (b - a) / (np * np);
    let tp2 = -2.0 * n2 * np * (b / a).ln() / (nm * nm);
    let tp3 = n2 * (1.0 / b - 1.0 / a) / 2.0;
    let tp4 = 16.0
        * n2
        * n2
        * (n2 * n2 + 1.0)
        * ((2.0 * np * b - nm * nm) / (2.0 * np * a - nm * nm)).ln()
        / (np.powi(3) * nm * nm);
    let tp5 = 16.0 * n2.powi(3) * (1.0 / (2.0 * np * b - nm * nm) - 1.0 / (2.0 * np * a - nm * nm))
        / np.powi(3);
    (ts + tp1 + tp2 + tp3 + tp4 + tp5) / (2.0 * sa2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e1_matches_known_values() {
        // Abramowitz & Stegun table 5.1.
        for (x, e1) in [
            (0.01, 4.037_929_576_538_1),
            (0.5, 0.559_773_594_776_16),
            (1.0, 0.219_383_934_395_52),
            (2.0, 0.048_900_510_708_061),
            (10.0, 4.156_968_929_685_3e-6),
        ] {
            let got = exp_integral_e1(x);
            assert!((got / e1 - 1.0).abs() < 1e-12, "E1({x}) = {got}, want {e1}");
        }
    }

    #[test]
    fn stern_tav_limits() {
        // Nearly no index step: nearly full transmission.
        let t = stern_tav(90.0, 1.01);
        assert!(t > 0.99 && t < 1.0, "{t}");
        // Normal-ish incidence on glass: 1 - ((n-1)/(n+1))^2 = 0.96 for n = 1.5; the 40° cone
        // is a little lower, isotropic (hemispherical) lower still (about 0.908).
        let t40 = stern_tav(40.0, 1.5);
        let t90 = stern_tav(90.0, 1.5);
        assert!(t40 < 0.96 && t40 > t90, "{t40} {t90}");
        // prosail's calctav(90, 1.5) and calctav(40, 1.5).
        assert!((t90 - 0.908_222_040_657_650_4).abs() < 1e-12, "{t90}");
        assert!((t40 - 0.958_424_035_706_867_8).abs() < 1e-12, "{t40}");
    }

    #[test]
    fn no_absorption_conserves_energy() {
        let (r, t) = plate_pile(1.7, 1.45, 0.0, 40.0);
        assert!((r + t - 1.0).abs() < 1e-9, "{r} + {t}");
        let (r, t) = plate_pile(1.7, 1.45, 0.3, 40.0);
        assert!(r + t < 1.0 && r > 0.0 && t > 0.0);
    }

    #[test]
    fn a_green_leaf_looks_green_and_bright_in_the_nir() {
        let s = prospect(&Pigments::default());
        let (r550, _) = s.at(550.0);
        let (r670, _) = s.at(670.0);
        let (r860, t860) = s.at(860.0);
        assert!(r550 > 1.5 * r670, "green peak {r550} vs red well {r670}");
        assert!(r860 > 0.4 && t860 > 0.4, "NIR plateau {r860} {t860}");
        assert!(
            s.r.iter()
                .zip(&s.t)
                .all(|(r, t)| *r >= 0.0 && *t >= 0.0 && r + t <= 1.0)
        );
    }

    #[test]
    fn validation_names_the_field() {
        let p = Pigments {
            cab: 500.0,
            ..Pigments::default()
        };
        let e = p.validate("pigments.").unwrap_err().to_string();
        assert!(e.contains("pigments.cab") && e.contains("500"), "{e}");
        let p = Pigments {
            prot: 0.001,
            ..Pigments::default()
        };
        let e = p.validate("--").unwrap_err().to_string();
        assert!(e.contains("--cm"), "{e}");
        let p = Pigments {
            n: f64::NAN,
            ..Pigments::default()
        };
        assert!(p.validate("").is_err());
    }

    #[test]
    fn pigments_read_from_toml_with_defaults() {
        let p: Pigments = toml::from_str("cab = 20.0").unwrap();
        assert_eq!(p.cab, 20.0);
        assert_eq!(p.cm, Pigments::default().cm);
        let p: Pigments = toml::from_str("prot = 0.001\ncbc = 0.008").unwrap();
        assert_eq!((p.cm, p.model()), (0.0, ProspectModel::Pro));
        let e = toml::from_str::<Pigments>("chlorophyll = 3.0").unwrap_err();
        assert!(e.to_string().contains("chlorophyll"), "{e}");
    }
}
