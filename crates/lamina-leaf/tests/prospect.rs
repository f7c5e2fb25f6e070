//! lamina's PROSPECT against an independent implementation (the `prosail` Python package,
//! `bench/spectral/prospect_reference.py`), at every wavelength 400-2500 nm.

use lamina_leaf::prospect::{LeafSpectrum, PROSPECT_LEN};
use lamina_leaf::{Pigments, ProspectModel, prospect};

/// The bar of the spectral issue: 0.002 absolute at every wavelength.
const BAR: f64 = 0.002;

struct Case {
    name: String,
    pigments: Pigments,
    model: ProspectModel,
    r: Vec<f64>,
    t: Vec<f64>,
}

fn reference() -> Vec<Case> {
    let text = include_str!("data/prospect_reference.tsv");
    let mut cases = Vec::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# case ") {
            let f: Vec<&str> = rest.split_whitespace().collect();
            let v: Vec<f64> = f[2..].iter().map(|x| x.parse().unwrap()).collect();
            let pigments = Pigments::from_values(v.try_into().unwrap());
            let model = match f[1] {
                "d" => ProspectModel::D,
                _ => ProspectModel::Pro,
            };
            cases.push(Case {
                name: f[0].to_owned(),
                pigments,
                model,
                r: Vec::new(),
                t: Vec::new(),
            });
        } else if !line.starts_with('#') && !line.starts_with("wavelength") {
            let v: Vec<f64> = line.split('\t').map(|x| x.parse().unwrap()).collect();
            for (k, c) in cases.iter_mut().enumerate() {
                c.r.push(v[1 + 2 * k] * 1e-5);
                c.t.push(v[2 + 2 * k] * 1e-5);
            }
        }
    }
    cases
}

#[test]
fn prospect_equals_prosail_at_every_wavelength() {
    let cases = reference();
    assert_eq!(cases.len(), 5);
    for c in &cases {
        assert_eq!(c.r.len(), PROSPECT_LEN, "{}", c.name);
        c.pigments.validate("").unwrap();
        assert_eq!(c.pigments.model(), c.model, "{}", c.name);
        let s = prospect(&c.pigments);
        let mut worst = (0.0f64, 0usize);
        for i in 0..PROSPECT_LEN {
            for d in [(s.r[i] - c.r[i]).abs(), (s.t[i] - c.t[i]).abs()] {
                if d > worst.0 {
                    worst = (d, i);
                }
            }
        }
        println!(
            "{} ({}): max |lamina - prosail| = {:.2e} at {} nm",
            c.name,
            c.model,
            worst.0,
            LeafSpectrum::wavelength(worst.1)
        );
        // The reference is rounded to 1e-5; anything above that rounding is a real difference.
        assert!(worst.0 < BAR, "{}: {worst:?}", c.name);
        assert!(
            worst.0 < 1e-5,
            "{}: {worst:?} (same model, should agree to rounding)",
            c.name
        );
    }
}
