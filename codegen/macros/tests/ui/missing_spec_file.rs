// A spec path that does not exist: the error points at the path literal.
qloop_macros::controller!("specs/no_such_controller.qloop");

fn main() {}
