ezy_derive::model! {
    pub struct Empty {
        param a = 1.0;
    }
}
fn main() {}
