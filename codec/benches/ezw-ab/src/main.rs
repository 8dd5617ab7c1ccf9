//! Same-process A/B timing of a base commit's EZW decoder (`old`) and this work tree's (`new`) on the same
//! N44W072 257² tile: interleaved rounds, median thread CPU time per configuration.
/// This thread's CPU time: the machine is shared, and wall time counts other processes'
/// slices; CPU time does not (cache effects remain).
struct Instant(f64);
impl Instant {
    fn now() -> Self {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        Instant(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    fn elapsed(&self) -> Elapsed {
        Elapsed(Instant::now().0 - self.0)
    }
}
struct Elapsed(f64);
impl Elapsed {
    fn as_secs_f64(&self) -> f64 {
        self.0
    }
}

fn dem() -> Vec<f64> {
    let bytes = std::fs::read(std::env::var("DEM").unwrap()).unwrap();
    bytes
        .chunks_exact(2)
        .map(|b| f64::from(i16::from_be_bytes([b[0], b[1]])))
        .collect()
}

/// Rows 300.., cols 500.. of the 1201² SRTM tile, `side`² samples.
fn tile(side: usize) -> (usize, Vec<f64>) {
    let dem = dem();
    let mut out = Vec::with_capacity(side * side);
    for r in 300..300 + side {
        out.extend_from_slice(&dem[r * 1201 + 500..r * 1201 + 500 + side]);
    }
    (side, out)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let (side, data) = tile(257);
    let go = new::Grid::new(side, side, data.clone()).unwrap();
    let gn = go.clone();
    let og = old::Grid::new(side, side, data).unwrap();
    let rounds: usize = std::env::var("ROUNDS").map_or(15, |v| v.parse().unwrap());
    let reps = 10;
    println!("| wavelet | T | old median ms | new median ms | old / new |");
    println!("|---|---|---|---|---|");
    for (wo, wn, name) in [
        (
            old::wavelet::Wavelet::Cdf97,
            new::wavelet::Wavelet::Cdf97,
            "cdf97",
        ),
        (
            old::wavelet::Wavelet::LeGall53,
            new::wavelet::Wavelet::LeGall53,
            "legall53",
        ),
    ] {
        let eo = old::ezw::encode(&og, &old::ezw::EncodeParams::new(wo, 1.0)).unwrap();
        let en = new::ezw::encode(&gn, &new::ezw::EncodeParams::new(wn, 1.0)).unwrap();
        for t in [0.5, 2.0, 8.0, 32.0] {
            let (mut to, mut tn) = (Vec::new(), Vec::new());
            for _ in 0..rounds {
                for _ in 0..reps {
                    let s = Instant::now();
                    std::hint::black_box(
                        old::ezw::decode(&eo.bytes, old::ezw::DecodeLimit::Threshold(t), 1 << 26)
                            .unwrap(),
                    );
                    to.push(s.elapsed().as_secs_f64() * 1e3);
                    let s = Instant::now();
                    std::hint::black_box(
                        new::ezw::decode(&en.bytes, new::ezw::DecodeLimit::Threshold(t), 1 << 26)
                            .unwrap(),
                    );
                    tn.push(s.elapsed().as_secs_f64() * 1e3);
                }
            }
            let (mo, mn) = (median(to), median(tn));
            println!("| {name} | {t} | {mo:.3} | {mn:.3} | {:.2}× |", mo / mn);
        }
    }
    // Decode to budget / 8 and mesh with the (same, new-crate) exact-error bintree within
    // 7/8 · budget, as the server and codec/benches/terrain.rs do.
    use new::bintree::{self, Hierarchy, TileErrors};
    let h = Hierarchy::new(side).unwrap();
    println!();
    println!("| decode+mesh wavelet | budget | old median ms | new median ms | old / new |");
    println!("|---|---|---|---|---|");
    for (wo, wn, name) in [
        (
            old::wavelet::Wavelet::Cdf97,
            new::wavelet::Wavelet::Cdf97,
            "cdf97",
        ),
        (
            old::wavelet::Wavelet::LeGall53,
            new::wavelet::Wavelet::LeGall53,
            "legall53",
        ),
    ] {
        let eo = old::ezw::encode(&og, &old::ezw::EncodeParams::new(wo, 1.0)).unwrap();
        let en = new::ezw::encode(&gn, &new::ezw::EncodeParams::new(wn, 1.0)).unwrap();
        for budget in [4.0, 16.0, 64.0] {
            let (mut to, mut tn) = (Vec::new(), Vec::new());
            for _ in 0..rounds {
                for _ in 0..reps {
                    let s = Instant::now();
                    let d = old::ezw::decode(
                        &eo.bytes,
                        old::ezw::DecodeLimit::Threshold(budget / 8.0),
                        1 << 26,
                    )
                    .unwrap();
                    let g = new::Grid::new(side, side, d.heights.data().to_vec()).unwrap();
                    let e = TileErrors::new(&h, &g);
                    std::hint::black_box(bintree::extract(&h, &e, &g, budget * 0.875, None));
                    to.push(s.elapsed().as_secs_f64() * 1e3);
                    let s = Instant::now();
                    let d = new::ezw::decode(
                        &en.bytes,
                        new::ezw::DecodeLimit::Threshold(budget / 8.0),
                        1 << 26,
                    )
                    .unwrap();
                    let e = TileErrors::new(&h, &d.heights);
                    std::hint::black_box(bintree::extract(
                        &h,
                        &e,
                        &d.heights,
                        budget * 0.875,
                        None,
                    ));
                    tn.push(s.elapsed().as_secs_f64() * 1e3);
                }
            }
            let (mo, mn) = (median(to), median(tn));
            println!(
                "| {name} | {budget} | {mo:.3} | {mn:.3} | {:.2}× |",
                mo / mn
            );
        }
    }
    // Encoding: plain on the 257² tile, and max-error mode (residual cut search) on a 512²
    // crop, fewer rounds (they are slow).
    println!();
    println!("| encode | old median ms | new median ms | old / new |");
    println!("|---|---|---|---|");
    let (side512, data512) = tile(512);
    let o512 = old::Grid::new(side512, side512, data512.clone()).unwrap();
    let n512 = new::Grid::new(side512, side512, data512).unwrap();
    let cases: [(&str, bool, Option<f64>); 5] = [
        ("257² cdf97", true, None),
        ("257² legall53", false, None),
        ("512² cdf97 max-error 1", true, Some(1.0)),
        ("512² cdf97 max-error 4", true, Some(4.0)),
        ("512² legall53 max-error 1", false, Some(1.0)),
    ];
    for (name, cdf, e) in cases {
        let (wo, wn) = if cdf {
            (old::wavelet::Wavelet::Cdf97, new::wavelet::Wavelet::Cdf97)
        } else {
            (
                old::wavelet::Wavelet::LeGall53,
                new::wavelet::Wavelet::LeGall53,
            )
        };
        let (og_e, ng_e) = if e.is_some() {
            (&o512, &n512)
        } else {
            (&og, &gn)
        };
        let po = old::ezw::EncodeParams {
            max_error: e,
            ..old::ezw::EncodeParams::new(wo, 1.0)
        };
        let pn = new::ezw::EncodeParams {
            max_error: e,
            ..new::ezw::EncodeParams::new(wn, 1.0)
        };
        let n = if e.is_some() { 5 } else { 3 * rounds };
        let (mut to, mut tn) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let s = Instant::now();
            std::hint::black_box(old::ezw::encode(og_e, &po).unwrap());
            to.push(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            std::hint::black_box(new::ezw::encode(ng_e, &pn).unwrap());
            tn.push(s.elapsed().as_secs_f64() * 1e3);
        }
        let (mo, mn) = (median(to), median(tn));
        println!("| {name} | {mo:.1} | {mn:.1} | {:.2}× |", mo / mn);
    }
    let _ = go;
}
