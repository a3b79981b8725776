use qloop_tests::random_spec::*;
#[test]
fn probe() {
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    let seed: u64 = std::env::var("S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7);
    let specs = sample(seed, n);
    let mut ok = 0;
    let mut errs = std::collections::BTreeMap::new();
    let t = std::time::Instant::now();
    let mut panics = 0;
    for s in &specs {
        let r = std::panic::catch_unwind(|| {
            qloop::compile_str(&s.src, &qloop::Target::default())
                .map(|_| ())
                .map_err(|e| e.message)
        });
        match r {
            Err(_) => {
                panics += 1;
                if panics <= 2 {
                    eprintln!("PANIC on\n{}", s.src);
                }
            }
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) => {
                let key: String = e.chars().take(22).collect();
                if !legitimate_refusal(&e)
                    || std::env::var("SHOW").map_or(false, |k| e.contains(&k))
                {
                    eprintln!("BAD: {}\n{}", e, s.src);
                }
                *errs.entry(key).or_insert(0) += 1;
            }
        }
    }
    eprintln!("ok {ok}/{n} panics {panics} in {:?}", t.elapsed());
    for (k, v) in errs {
        eprintln!("{v:5} {k}");
    }
}
