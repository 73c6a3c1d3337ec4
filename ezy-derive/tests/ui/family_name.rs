// An item inside a family is named NAME[VAR].
ezy_derive::model! {
    pub struct M {
        count N = 4;
        for i in 0..N {
            body link(x, y, phi) { mass: 1.0, inertia: 0.1 }
        }
    }
}
fn main() {}
