// A family's variable names the element's index only in the items of that
// family: in a single item, or in a family of another variable, it is an
// error at the token, and a family variable may not share its name with a
// parameter (inside the family it would name the index).
ezy_derive::model! {
    pub struct M {
        count N = 3;
        param l = 1.0;
        param j = 2.0;
        body base(xb, yb, phib) { mass: 1.0, inertia: 1.0 }
        point H on base at (i * l, 0);
        for i in 0..N {
            // the index in every expression of the family: fine
            body link[i](x, y, phi) { mass: 1.0 + i, inertia: 0.1 * (i + 1) }
            point F[i] on link[i] at (i * l, 0);
            hinge G[i]: F[i] = ground(i * l, 0);
        }
        for k in 0..N {
            body arm[k](xa, ya, phia) { mass: 1.0, inertia: 0.1 }
            point E[k] on arm[k] at (i * l, k);
        }
        for j in 0..N {
            body rod[j](xr, yr, phir) { mass: 1.0, inertia: 0.1 }
        }
        hinge K: H = ground(0, i);
        skate S: H along (i, 1);
    }
}
fn main() {}
