qloop_macros::controller! {
    controller norange {
        period 0.1 "s";
        input fc "kN";
        output y;
        step {
            y = fc;
        }
    }
}

fn main() {}
