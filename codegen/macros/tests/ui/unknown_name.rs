qloop_macros::controller! {
    controller unknown {
        period 0.1 "s";
        input fc: [0.0, 5.0] "kN";
        output y;
        step {
            y = fc * gain;
        }
    }
}

fn main() {}
