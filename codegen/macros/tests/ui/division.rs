qloop_macros::controller! {
    controller divides {
        period 0.1 "s";
        input fc: [0.1, 5.0] "kN";
        state kc: [0.1, 5.0] = 1.0;
        output y;
        step {
            kc = 1.25 / fc;
            y = kc;
        }
    }
}

fn main() {}
