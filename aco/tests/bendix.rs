//! The Bendix ACO index (Koren's survey, eqs. 1–3) and its optimiser against hand-computed cases.

use qloop_aco::bendix::{
    index, mrr, optimise, twr, Economics, Milling, EXAMPLE, EXAMPLE_ECONOMICS,
};

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs()
}

/// Eqs. 1–3 by hand: w = 0.5 in, a = 0.2 in, V = 10 in/min give MRR = 1 in³/min. At 600 °F,
/// TWR = 2e-5·1 + 2e-7·600 = 1.4e-4 in/min. With C1 = 1, t1 = 2, C2 = 20, W0 = 0.015:
/// β = 1: φ = 1/(1 + 22·1.4e-4/0.015) = 1/1.205333… = 0.829646;
/// β = 0: φ = 1/(1 + 2·1.4e-4/0.015) = 1/1.018666… = 0.981675.
#[test]
fn index_by_hand() {
    let e = EXAMPLE_ECONOMICS;
    let r = mrr(0.5, 0.2, 10.0);
    assert_eq!(r, 1.0);
    let w = twr(&e, r, 600.0, 0.0);
    assert!(close(w, 1.4e-4, 1e-12));
    assert!(close(index(&e, r, w, 1.0), 0.829646, 1e-6));
    assert!(close(index(&e, r, w, 0.0), 0.981675, 1e-6));
    // The torque-rate term of eq. 2: K3 = 1e-6 in/(lbf·in) and dT/dt = 10 lbf·in/min add 1e-5.
    let e3 = Economics { k3: 1e-6, ..e };
    assert!(close(twr(&e3, r, 600.0, 10.0), 1.5e-4, 1e-12));
}

/// β = 0 is the production rate (volume per minute including tool changes) over C1; β = 1
/// the volume per dollar (the survey's two limits).
#[test]
fn beta_limits_are_rate_and_cost() {
    let e = EXAMPLE_ECONOMICS;
    let (r, w) = (3.0, 2e-4);
    let tool_life = e.w0 / w; // min
    let rate = r / (1.0 + e.t1 / tool_life); // in³/min including tool changes
    assert!(close(index(&e, r, w, 0.0), rate / e.c1, 1e-12));
    let cost_per_min = e.c1 + (e.c1 * e.t1 + e.c2) / tool_life;
    assert!(close(index(&e, r, w, 1.0), r / cost_per_min, 1e-12));
}

/// The tooth load where the torque is at its limit, and the speed where the temperature then
/// is: T = U0·F0^m·w·a·z·f_t^(1−m)/(2π) and θ = Θ0·(N/N0)^p·(f_t/F0)^q, solved for f_t and N.
fn torque_temperature_vertex(m: &Milling) -> (f64, f64) {
    let c = m.u0 * m.f0.powf(m.m) * m.width * m.depth * m.teeth / (2.0 * std::f64::consts::PI);
    let ft = (m.torque_max / c).powf(1.0 / (1.0 - m.m));
    let n = m.n0 * (m.temp_max / (m.theta0 * (ft / m.f0).powf(m.q))).powf(1.0 / m.p);
    (ft * m.teeth * n, n)
}

/// With q < p < 1 (0.2 < 0.5), φ rises with feed and speed and falls with speed along the
/// temperature limit, so the optimum is at the torque limit and the temperature limit, for
/// every β (the module docs derive it).
#[test]
fn optimum_is_on_the_torque_and_temperature_limits() {
    let (v, n) = torque_temperature_vertex(&EXAMPLE);
    println!("hand: V = {v:.3} in/min, N = {n:.1} rpm");
    for beta in [0.0, 0.5, 1.0] {
        let o = optimise(&EXAMPLE, &EXAMPLE_ECONOMICS, beta).unwrap();
        println!("β = {beta}: {o:?}");
        assert!(close(o.feed, v, 1e-5) && close(o.speed, n, 1e-5), "{o:?}");
        assert_eq!(o.active, vec!["torque", "temperature"]);
    }
}

/// With θ growing faster than speed (p = 2), a wear rate more sensitive to it (K2 = 4e-6) and
/// the temperature limit lifted out of the way (so that only the wear trade-off sets the
/// speed), there is a best speed inside the limits:
/// N* = [C1/(k·K2·Θ′·(p − 1))]^(1/p) with Θ′ = Θ0·N0^−p·(f_t/F0)^q and
/// k = (C1·t1 + C2·β)/W0, at the torque-limited tooth load. Weighing the tool's cost (β = 1)
/// lowers it against the production rate (β = 0).
#[test]
fn hot_cut_has_an_inner_best_speed_that_falls_with_beta() {
    let m = Milling {
        p: 2.0,
        theta0: 300.0,
        temp_max: 5000.0,
        feed_max: 200.0,
        ..EXAMPLE
    };
    let e = Economics {
        k2: 4e-6,
        ..EXAMPLE_ECONOMICS
    };
    let c = m.u0 * m.f0.powf(m.m) * m.width * m.depth * m.teeth / (2.0 * std::f64::consts::PI);
    let ft = (m.torque_max / c).powf(1.0 / (1.0 - m.m));
    let mut speeds = Vec::new();
    for beta in [0.0, 1.0] {
        let k = (e.c1 * e.t1 + e.c2 * beta) / e.w0;
        let theta_p = m.theta0 * m.n0.powf(-m.p) * (ft / m.f0).powf(m.q);
        let n_star = (e.c1 / (k * e.k2 * theta_p * (m.p - 1.0))).powf(1.0 / m.p);
        let o = optimise(&m, &e, beta).unwrap();
        println!(
            "β = {beta}: hand N* = {n_star:.1} rpm, V* = {:.2}; {o:?}",
            ft * m.teeth * n_star
        );
        assert!(
            n_star > m.speed.0 && n_star < m.speed.1,
            "N* inside the range"
        );
        assert!(close(o.speed, n_star, 1e-4), "{o:?} vs {n_star}");
        assert!(close(o.feed, ft * m.teeth * n_star, 1e-4));
        assert_eq!(o.active, vec!["torque"]);
        speeds.push(o.speed);
    }
    assert!(speeds[1] < speeds[0], "{speeds:?}");
}

/// A top speed below the temperature's: the optimum moves to the speed bound.
#[test]
fn speed_bound_binds_when_lower() {
    let (_, n) = torque_temperature_vertex(&EXAMPLE);
    let m = Milling {
        speed: (200.0, 0.8 * n),
        ..EXAMPLE
    };
    let o = optimise(&m, &EXAMPLE_ECONOMICS, 0.5).unwrap();
    assert_eq!(o.active, vec!["torque", "max speed"], "{o:?}");
}

/// With q > p (tooth load heating more than speed: q = 0.8, p = 0.5) the removal rate grows
/// with speed along the temperature limit, so the optimum leaves the torque limit for the
/// temperature limit at top speed (the module docs' third case).
#[test]
fn load_sensitive_temperature_moves_the_optimum_to_top_speed() {
    let m = Milling { q: 0.8, ..EXAMPLE };
    let o = optimise(&m, &EXAMPLE_ECONOMICS, 0.5).unwrap();
    println!("{o:?}");
    assert_eq!(o.active, vec!["temperature", "max speed"], "{o:?}");
}
