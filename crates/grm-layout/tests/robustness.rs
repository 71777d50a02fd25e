//! Library code never panics on user input: mutated sidecars and GeoJSON
//! texts (bytes flipped, cut, duplicated; drawn from
//! `grm_testkit::Rng::seeded`) are read with typed errors, what loads is
//! valid, and a sidecar read back from its canonical text reads the same.

use grm_layout::geojson_io;
use grm_layout::sidecar;
use grm_layout::validity::check;
use grm_testkit::Rng;

const SIDECAR: &str = include_str!("../../../examples/city.layout.json");
const PARK: &str = include_str!("../../../examples/city_park.geojson");

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut b = text.as_bytes().to_vec();
    let alphabet = b"{}[]\":,0123456789.-eE abcdefghijklmnopqrstuvwxyz";
    for _ in 0..1 + rng.below(4u32) {
        if b.is_empty() {
            break;
        }
        let i = rng.below(b.len());
        match rng.below(4u32) {
            0 => b[i] = *rng.pick(alphabet),
            1 => {
                b.remove(i);
            }
            2 => {
                let j = (i + rng.below(40usize)).min(b.len());
                let chunk = b[i..j].to_vec();
                b.splice(i..i, chunk);
            }
            _ => b.truncate(i),
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

#[test]
fn mutated_sidecars_read_with_typed_errors() {
    let mut rng = Rng::seeded(0x1a70_0005);
    let mut parsed = 0;
    for case in 0..400 {
        let text = mutate(&mut rng, SIDECAR);
        let (doc, errs) = sidecar::read(&text);
        if errs.is_empty() {
            parsed += 1;
        }
        for e in &errs {
            assert!(
                e.kind.code().starts_with("R102") && !e.path.is_empty(),
                "case {case}: {e}"
            );
        }
        let canonical = sidecar::write(&doc);
        let (again, errs) = sidecar::read(&canonical);
        assert!(errs.is_empty(), "case {case}: {errs:?}\n{canonical}");
        assert_eq!(sidecar::write(&again), canonical, "case {case}");
    }
    assert!(parsed > 0);
}

#[test]
fn mutated_geojson_loads_what_is_good_and_stays_valid() {
    let mut rng = Rng::seeded(0x1a70_0006);
    for case in 0..400 {
        let text = mutate(&mut rng, PARK);
        let r = geojson_io::read(&text, "park.geojson");
        for e in &r.errors {
            assert!(e.kind.code().starts_with("R10"), "case {case}: {e}");
        }
        let v = check(&r.layout);
        assert!(
            v.is_empty(),
            "case {case}: {:?}\n{text}",
            v.iter().map(|x| x.describe()).collect::<Vec<_>>()
        );
        // What loaded writes and reads back the same.
        let out = geojson_io::write(&r.layout, None);
        let back = geojson_io::read(&out, "again");
        assert!(back.errors.is_empty(), "case {case}: {:?}", back.errors);
        assert_eq!(geojson_io::write(&back.layout, None), out, "case {case}");
    }
}
