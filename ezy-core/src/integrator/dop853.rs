//! DOP853: the explicit Runge-Kutta method of Dormand & Prince of order 8
//! with embedded error estimators of orders 5 and 3, and a dense output of
//! order 7, as in Hairer's code DOP853 (Hairer, Nørsett & Wanner, Solving
//! ODEs I, 2nd ed., §II.10; the codes `dop853.f` / `dop853.c`).
//!
//! The coefficients are Hairer's published constants (30 digits), as
//! reproduced in Numerical Recipes 3rd ed., `stepperdopr853.h`
//! (`Dopr853_constants`), and checked constant by constant against SciPy's
//! `scipy/integrate/_ivp/dop853_coefficients.py`, which transcribes the
//! same code.
//!
//! A step uses 12 stages: `k1 = F(t, y)` is given and stages 2..=12 cost 11
//! evaluations. The new state's derivative `F(t + h, y_new)` (the next
//! step's `k1`, Hairer's "stage 13") is not part of the error estimate, so
//! the driver evaluates it only for an accepted step, at the projected
//! state: 12 evaluations per accepted step, 11 per rejected one (Hairer's
//! code spends 12 on each and one more after a projection). The dense
//! output adds stages 14, 15 and 16 (3 evaluations) on a step with an
//! output.

// The constants are kept with the sources' 30 digits, verbatim, so that
// they can be compared with them digit for digit.
#![expect(clippy::excessive_precision, reason = "the coefficients as the reference code prints them, digit for digit")]

use super::{Rhs, state_len};
use crate::error::SimError;
use crate::integrator::adaptive::{EmbeddedRk, Tolerance};

/// `let v = &v[..n];` (or `&mut`) for each named slice or vector. Cut one
/// by one rather than through `array::map`: the map's closure runs in an
/// outlined `try_map`, the cut lengths are lost, and every component
/// read is bounds-checked again (callgrind: DOP853's interpolation 245
/// instructions a sample against 137).
macro_rules! cut {
    ($n:expr; mut $($v:ident),+) => { $(let $v = &mut $v[..$n];)+ };
    ($n:expr; $($v:ident),+) => { $(let $v = &$v[..$n];)+ };
}

// Nodes.
const C2: f64 = 0.526001519587677318785587544488e-01;
const C3: f64 = 0.789002279381515978178381316732e-01;
const C4: f64 = 0.118350341907227396726757197510e+00;
const C5: f64 = 0.281649658092772603273242802490e+00;
const C6: f64 = 0.333333333333333333333333333333e+00;
const C7: f64 = 0.25e+00;
const C8: f64 = 0.307692307692307692307692307692e+00;
const C9: f64 = 0.651282051282051282051282051282e+00;
const C10: f64 = 0.6e+00;
const C11: f64 = 0.857142857142857142857142857142e+00;
const C14: f64 = 0.1e+00;
const C15: f64 = 0.2e+00;
const C16: f64 = 0.777777777777777777777777777778e+00;

// Weights of the order-8 solution (b2..b5 are zero).
const B1: f64 = 5.42937341165687622380535766363e-2;
const B6: f64 = 4.45031289275240888144113950566e0;
const B7: f64 = 1.89151789931450038304281599044e0;
const B8: f64 = -5.8012039600105847814672114227e0;
const B9: f64 = 3.1116436695781989440891606237e-1;
const B10: f64 = -1.52160949662516078556178806805e-1;
const B11: f64 = 2.01365400804030348374776537501e-1;
const B12: f64 = 4.47106157277725905176885569043e-2;

// Weights of the order-3 estimator.
const BHH1: f64 = 0.244094488188976377952755905512e+00;
const BHH2: f64 = 0.733846688281611857341361741547e+00;
const BHH3: f64 = 0.220588235294117647058823529412e-01;

// Order-5 error estimator (difference of weights).
const ER1: f64 = 0.1312004499419488073250102996e-01;
const ER6: f64 = -0.1225156446376204440720569753e+01;
const ER7: f64 = -0.4957589496572501915214079952e+00;
const ER8: f64 = 0.1664377182454986536961530415e+01;
const ER9: f64 = -0.3503288487499736816886487290e+00;
const ER10: f64 = 0.3341791187130174790297318841e+00;
const ER11: f64 = 0.8192320648511571246570742613e-01;
const ER12: f64 = -0.2235530786388629525884427845e-01;

// The Runge-Kutta matrix of stages 2..=12.
const A21: f64 = 5.26001519587677318785587544488e-2;
const A31: f64 = 1.97250569845378994544595329183e-2;
const A32: f64 = 5.91751709536136983633785987549e-2;
const A41: f64 = 2.95875854768068491816892993775e-2;
const A43: f64 = 8.87627564304205475450678981324e-2;
const A51: f64 = 2.41365134159266685502369798665e-1;
const A53: f64 = -8.84549479328286085344864962717e-1;
const A54: f64 = 9.24834003261792003115737966543e-1;
const A61: f64 = 3.7037037037037037037037037037e-2;
const A64: f64 = 1.70828608729473871279604482173e-1;
const A65: f64 = 1.25467687566822425016691814123e-1;
const A71: f64 = 3.7109375e-2;
const A74: f64 = 1.70252211019544039314978060272e-1;
const A75: f64 = 6.02165389804559606850219397283e-2;
const A76: f64 = -1.7578125e-2;
const A81: f64 = 3.70920001185047927108779319836e-2;
const A84: f64 = 1.70383925712239993810214054705e-1;
const A85: f64 = 1.07262030446373284651809199168e-1;
const A86: f64 = -1.53194377486244017527936158236e-2;
const A87: f64 = 8.27378916381402288758473766002e-3;
const A91: f64 = 6.24110958716075717114429577812e-1;
const A94: f64 = -3.36089262944694129406857109825e0;
const A95: f64 = -8.68219346841726006818189891453e-1;
const A96: f64 = 2.75920996994467083049415600797e1;
const A97: f64 = 2.01540675504778934086186788979e1;
const A98: f64 = -4.34898841810699588477366255144e1;
const A101: f64 = 4.77662536438264365890433908527e-1;
const A104: f64 = -2.48811461997166764192642586468e0;
const A105: f64 = -5.90290826836842996371446475743e-1;
const A106: f64 = 2.12300514481811942347288949897e1;
const A107: f64 = 1.52792336328824235832596922938e1;
const A108: f64 = -3.32882109689848629194453265587e1;
const A109: f64 = -2.03312017085086261358222928593e-2;
const A111: f64 = -9.3714243008598732571704021658e-1;
const A114: f64 = 5.18637242884406370830023853209e0;
const A115: f64 = 1.09143734899672957818500254654e0;
const A116: f64 = -8.14978701074692612513997267357e0;
const A117: f64 = -1.85200656599969598641566180701e1;
const A118: f64 = 2.27394870993505042818970056734e1;
const A119: f64 = 2.49360555267965238987089396762e0;
const A1110: f64 = -3.0467644718982195003823669022e0;
const A121: f64 = 2.27331014751653820792359768449e0;
const A124: f64 = -1.05344954667372501984066689879e1;
const A125: f64 = -2.00087205822486249909675718444e0;
const A126: f64 = -1.79589318631187989172765950534e1;
const A127: f64 = 2.79488845294199600508499808837e1;
const A128: f64 = -2.85899827713502369474065508674e0;
const A129: f64 = -8.87285693353062954433549289258e0;
const A1210: f64 = 1.23605671757943030647266201528e1;
const A1211: f64 = 6.43392746015763530355970484046e-1;

// Stages 14..=16 of the dense output (stage 13 is F(t + h, y_new)).
const A141: f64 = 5.61675022830479523392909219681e-2;
const A147: f64 = 2.53500210216624811088794765333e-1;
const A148: f64 = -2.46239037470802489917441475441e-1;
const A149: f64 = -1.24191423263816360469010140626e-1;
const A1410: f64 = 1.5329179827876569731206322685e-1;
const A1411: f64 = 8.20105229563468988491666602057e-3;
const A1412: f64 = 7.56789766054569976138603589584e-3;
const A1413: f64 = -8.298e-3;
const A151: f64 = 3.18346481635021405060768473261e-2;
const A156: f64 = 2.83009096723667755288322961402e-2;
const A157: f64 = 5.35419883074385676223797384372e-2;
const A158: f64 = -5.49237485713909884646569340306e-2;
const A1511: f64 = -1.08347328697249322858509316994e-4;
const A1512: f64 = 3.82571090835658412954920192323e-4;
const A1513: f64 = -3.40465008687404560802977114492e-4;
const A1514: f64 = 1.41312443674632500278074618366e-1;
const A161: f64 = -4.28896301583791923408573538692e-1;
const A166: f64 = -4.69762141536116384314449447206e0;
const A167: f64 = 7.68342119606259904184240953878e0;
const A168: f64 = 4.06898981839711007970213554331e0;
const A169: f64 = 3.56727187455281109270669543021e-1;
const A1613: f64 = -1.39902416515901462129418009734e-3;
const A1614: f64 = 2.9475147891527723389556272149e0;
const A1615: f64 = -9.15095847217987001081870187138e0;

// Dense output: coefficients of rcont5..rcont8 (HNW's d4j..d7j).
const D41: f64 = -0.84289382761090128651353491142e+01;
const D46: f64 = 0.56671495351937776962531783590e+00;
const D47: f64 = -0.30689499459498916912797304727e+01;
const D48: f64 = 0.23846676565120698287728149680e+01;
const D49: f64 = 0.21170345824450282767155149946e+01;
const D410: f64 = -0.87139158377797299206789907490e+00;
const D411: f64 = 0.22404374302607882758541771650e+01;
const D412: f64 = 0.63157877876946881815570249290e+00;
const D413: f64 = -0.88990336451333310820698117400e-01;
const D414: f64 = 0.18148505520854727256656404962e+02;
const D415: f64 = -0.91946323924783554000451984436e+01;
const D416: f64 = -0.44360363875948939664310572000e+01;
const D51: f64 = 0.10427508642579134603413151009e+02;
const D56: f64 = 0.24228349177525818288430175319e+03;
const D57: f64 = 0.16520045171727028198505394887e+03;
const D58: f64 = -0.37454675472269020279518312152e+03;
const D59: f64 = -0.22113666853125306036270938578e+02;
const D510: f64 = 0.77334326684722638389603898808e+01;
const D511: f64 = -0.30674084731089398182061213626e+02;
const D512: f64 = -0.93321305264302278729567221706e+01;
const D513: f64 = 0.15697238121770843886131091075e+02;
const D514: f64 = -0.31139403219565177677282850411e+02;
const D515: f64 = -0.93529243588444783865713862664e+01;
const D516: f64 = 0.35816841486394083752465898540e+02;
const D61: f64 = 0.19985053242002433820987653617e+02;
const D66: f64 = -0.38703730874935176555105901742e+03;
const D67: f64 = -0.18917813819516756882830838328e+03;
const D68: f64 = 0.52780815920542364900561016686e+03;
const D69: f64 = -0.11573902539959630126141871134e+02;
const D610: f64 = 0.68812326946963000169666922661e+01;
const D611: f64 = -0.10006050966910838403183860980e+01;
const D612: f64 = 0.77771377980534432092869265740e+00;
const D613: f64 = -0.27782057523535084065932004339e+01;
const D614: f64 = -0.60196695231264120758267380846e+02;
const D615: f64 = 0.84320405506677161018159903784e+02;
const D616: f64 = 0.11992291136182789328035130030e+02;
const D71: f64 = -0.25693933462703749003312586129e+02;
const D76: f64 = -0.15418974869023643374053993627e+03;
const D77: f64 = -0.23152937917604549567536039109e+03;
const D78: f64 = 0.35763911791061412378285349910e+03;
const D79: f64 = 0.93405324183624310003907691704e+02;
const D710: f64 = -0.37458323136451633156875139351e+02;
const D711: f64 = 0.10409964950896230045147246184e+03;
const D712: f64 = 0.29840293426660503123344363579e+02;
const D713: f64 = -0.43533456590011143754432175058e+02;
const D714: f64 = 0.96324553959188282948394950600e+02;
const D715: f64 = -0.39177261675615439165231486172e+02;
const D716: f64 = -0.14972683625798562581422125276e+03;

/// The order-8 solution `y_new = y + h (b1 k1 + b6 k6 + ... + b12 k12)`
/// and the sums of squares of the scaled order-5 and order-3 error
/// estimates (HNW's `err` and `err2`), in one loop. `y_new` is its only
/// output and a parameter of its own, so the loop needs no overlap checks
/// (see `stage_arg!` in the parent module).
#[inline(always)]
fn solution(y: &[f64], ks: [&[f64]; 8], h: f64, tol: &Tolerance, y_new: &mut [f64]) -> (f64, f64) {
    let n = y_new.len();
    let y = &y[..n];
    let [k1, k6, k7, k8, k9, k10, k11, k12] = ks;
    cut!(n; k1, k6, k7, k8, k9, k10, k11, k12);
    let (mut err5, mut err3) = (0.0, 0.0);
    for i in 0..n {
        let (bk, e5, e3) = combinations([k1, k6, k7, k8, k9, k10, k11, k12], i);
        y_new[i] = y[i] + h * bk;
        let sk = tol.scale(y[i], y_new[i]);
        err3 += (e3 / sk).powi(2);
        err5 += (e5 / sk).powi(2);
    }
    (err5, err3)
}

/// Component `i` of the stages' three combinations: the order-8 slope
/// `b1 k1 + b6 k6 + ... + b12 k12` and the order-5 and order-3 error
/// estimates (without the factor `h`), for [`solution`] and
/// [`EmbeddedRk::error_vectors`].
#[inline(always)]
fn combinations([k1, k6, k7, k8, k9, k10, k11, k12]: [&[f64]; 8], i: usize) -> (f64, f64, f64) {
    let bk =
        B1 * k1[i] + B6 * k6[i] + B7 * k7[i] + B8 * k8[i] + B9 * k9[i] + B10 * k10[i] + B11 * k11[i] + B12 * k12[i];
    let e3 = bk - BHH1 * k1[i] - BHH2 * k9[i] - BHH3 * k12[i];
    let e5 = ER1 * k1[i]
        + ER6 * k6[i]
        + ER7 * k7[i]
        + ER8 * k8[i]
        + ER9 * k9[i]
        + ER10 * k10[i]
        + ER11 * k11[i]
        + ER12 * k12[i];
    (bk, e5, e3)
}

/// HNW's norm `|h| err5 / sqrt(n (err5 + 0.01 err3))` from the sums of
/// squares of the scaled order-5 and order-3 estimates.
#[inline(always)]
fn error_norm_853(h: f64, err5: f64, err3: f64, n: usize) -> f64 {
    let mut deno = err5 + 0.01 * err3;
    if deno <= 0.0 {
        deno = 1.0;
    }
    h.abs() * err5 / (n as f64 * deno).sqrt()
}

/// HNW's dense-output coefficients `rcont1..8` of the step from `y` to
/// `y_new` of size `h`, from its stages `k1, k6..k16`, in one loop whose
/// eight outputs are parameters of their own (see `stage_arg!` in the parent module).
#[expect(
    clippy::too_many_arguments,
    reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
)]
#[inline(always)]
fn dense_coefficients(
    y: &[f64],
    y_new: &[f64],
    h: f64,
    ks: [&[f64]; 12],
    r1: &mut [f64],
    r2: &mut [f64],
    r3: &mut [f64],
    r4: &mut [f64],
    r5: &mut [f64],
    r6: &mut [f64],
    r7: &mut [f64],
    r8: &mut [f64],
) {
    let n = r1.len();
    let (y, y_new) = (&y[..n], &y_new[..n]);
    let [k1, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16] = ks;
    cut!(n; k1, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16);
    cut!(n; mut r2, r3, r4, r5, r6, r7, r8);
    for i in 0..n {
        let ydiff = y_new[i] - y[i];
        let bspl = h * k1[i] - ydiff;
        r1[i] = y[i];
        r2[i] = ydiff;
        r3[i] = bspl;
        r4[i] = ydiff - h * k13[i] - bspl;
        r5[i] = h
            * (D41 * k1[i]
                + D46 * k6[i]
                + D47 * k7[i]
                + D48 * k8[i]
                + D49 * k9[i]
                + D410 * k10[i]
                + D411 * k11[i]
                + D412 * k12[i]
                + D413 * k13[i]
                + D414 * k14[i]
                + D415 * k15[i]
                + D416 * k16[i]);
        r6[i] = h
            * (D51 * k1[i]
                + D56 * k6[i]
                + D57 * k7[i]
                + D58 * k8[i]
                + D59 * k9[i]
                + D510 * k10[i]
                + D511 * k11[i]
                + D512 * k12[i]
                + D513 * k13[i]
                + D514 * k14[i]
                + D515 * k15[i]
                + D516 * k16[i]);
        r7[i] = h
            * (D61 * k1[i]
                + D66 * k6[i]
                + D67 * k7[i]
                + D68 * k8[i]
                + D69 * k9[i]
                + D610 * k10[i]
                + D611 * k11[i]
                + D612 * k12[i]
                + D613 * k13[i]
                + D614 * k14[i]
                + D615 * k15[i]
                + D616 * k16[i]);
        r8[i] = h
            * (D71 * k1[i]
                + D76 * k6[i]
                + D77 * k7[i]
                + D78 * k8[i]
                + D79 * k9[i]
                + D710 * k10[i]
                + D711 * k11[i]
                + D712 * k12[i]
                + D713 * k13[i]
                + D714 * k14[i]
                + D715 * k15[i]
                + D716 * k16[i]);
    }
}

/// One attempt of [`Dop853`] ([`EmbeddedRk::attempt`]) on a state of
/// length `N` known at compile time (0: read at run time; see `by_len!`).
#[expect(
    clippy::too_many_arguments,
    reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
)]
#[inline(always)]
fn attempt_len<const N: usize, R: Rhs>(
    s: &mut Dop853,
    rhs: &mut R,
    t: f64,
    y: &[f64],
    k1: &[f64],
    h: f64,
    tol: &Tolerance,
    y_new: &mut [f64],
) -> Result<f64, SimError> {
    let Dop853 { k, tmp, .. } = s;
    let n = state_len::<N>(y.len());
    // every slice cut to n once, so the loops below carry no bounds checks
    let [k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12] = k;
    cut!(n; mut k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12);
    let (tmp, y, k1, y_new) = (&mut tmp[..n], &y[..n], &k1[..n], &mut y_new[..n]);
    // HNW's `(h a21) k1`, in its order of operations
    stage_arg!(tmp, y, h * A21, [1.0], [k1]);
    rhs.eval(t + C2 * h, tmp, k2)?;
    stage_arg!(tmp, y, h, [A31, A32], [k1, k2]);
    rhs.eval(t + C3 * h, tmp, k3)?;
    stage_arg!(tmp, y, h, [A41, A43], [k1, k3]);
    rhs.eval(t + C4 * h, tmp, k4)?;
    stage_arg!(tmp, y, h, [A51, A53, A54], [k1, k3, k4]);
    rhs.eval(t + C5 * h, tmp, k5)?;
    stage_arg!(tmp, y, h, [A61, A64, A65], [k1, k4, k5]);
    rhs.eval(t + C6 * h, tmp, k6)?;
    stage_arg!(tmp, y, h, [A71, A74, A75, A76], [k1, k4, k5, k6]);
    rhs.eval(t + C7 * h, tmp, k7)?;
    stage_arg!(tmp, y, h, [A81, A84, A85, A86, A87], [k1, k4, k5, k6, k7]);
    rhs.eval(t + C8 * h, tmp, k8)?;
    stage_arg!(tmp, y, h, [A91, A94, A95, A96, A97, A98], [k1, k4, k5, k6, k7, k8]);
    rhs.eval(t + C9 * h, tmp, k9)?;
    stage_arg!(tmp, y, h, [A101, A104, A105, A106, A107, A108, A109], [k1, k4, k5, k6, k7, k8, k9]);
    rhs.eval(t + C10 * h, tmp, k10)?;
    stage_arg!(tmp, y, h, [A111, A114, A115, A116, A117, A118, A119, A1110], [k1, k4, k5, k6, k7, k8, k9, k10],);
    rhs.eval(t + C11 * h, tmp, k11)?;
    stage_arg!(
        tmp,
        y,
        h,
        [A121, A124, A125, A126, A127, A128, A129, A1210, A1211],
        [k1, k4, k5, k6, k7, k8, k9, k10, k11],
    );
    rhs.eval(t + h, tmp, k12)?;
    // The solution, and the two error estimators of HNW's code: `err5`
    // (order 5) and `err3` (order 3), each a sum of squares of scaled
    // components, combined as `|h| err5 / sqrt(n (err5 + 0.01 err3))`.
    let (err5, err3) = solution(y, [k1, k6, k7, k8, k9, k10, k11, k12], h, tol, y_new);
    if n == 0 {
        return Ok(0.0);
    }
    Ok(error_norm_853(h, err5, err3, n))
}

/// [`EmbeddedRk::prepare_dense`] of [`Dop853`] on a state of length `N`
/// (as [`attempt_len`]).
#[expect(
    clippy::too_many_arguments,
    reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
)]
#[inline(always)]
fn prepare_dense_len<const N: usize, R: Rhs>(
    s: &mut Dop853,
    rhs: &mut R,
    t: f64,
    y: &[f64],
    k1: &[f64],
    h: f64,
    y_new: &[f64],
    k13: &[f64],
) -> Result<(), SimError> {
    let Dop853 { k, kd, tmp, cont } = s;
    let n = state_len::<N>(y.len());
    let [_, _, _, _, k6, k7, k8, k9, k10, k11, k12] = k;
    cut!(n; mut k6, k7, k8, k9, k10, k11, k12);
    let [k14, k15, k16] = kd;
    cut!(n; mut k14, k15, k16);
    let [r1, r2, r3, r4, r5, r6, r7, r8] = rows_mut(&mut cont[..8 * n], n);
    let (tmp, y, k1, y_new, k13) = (&mut tmp[..n], &y[..n], &k1[..n], &y_new[..n], &k13[..n]);
    stage_arg!(tmp, y, h, [A141, A147, A148, A149, A1410, A1411, A1412, A1413], [k1, k7, k8, k9, k10, k11, k12, k13],);
    rhs.eval(t + C14 * h, tmp, k14)?;
    stage_arg!(tmp, y, h, [A151, A156, A157, A158, A1511, A1512, A1513, A1514], [k1, k6, k7, k8, k11, k12, k13, k14],);
    rhs.eval(t + C15 * h, tmp, k15)?;
    stage_arg!(tmp, y, h, [A161, A166, A167, A168, A169, A1613, A1614, A1615], [k1, k6, k7, k8, k9, k13, k14, k15],);
    rhs.eval(t + C16 * h, tmp, k16)?;
    let ks = [k1, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16];
    dense_coefficients(y, y_new, h, ks, r1, r2, r3, r4, r5, r6, r7, r8);
    Ok(())
}

/// The eight rows of length `n` of the dense output's coefficients
/// `cont` (8 n long), HNW's `rcont1..8`.
#[inline(always)]
fn rows_mut(cont: &mut [f64], n: usize) -> [&mut [f64]; 8] {
    let (r1, c) = cont.split_at_mut(n);
    let (r2, c) = c.split_at_mut(n);
    let (r3, c) = c.split_at_mut(n);
    let (r4, c) = c.split_at_mut(n);
    let (r5, c) = c.split_at_mut(n);
    let (r6, c) = c.split_at_mut(n);
    let (r7, r8) = c.split_at_mut(n);
    [r1, r2, r3, r4, r5, r6, r7, &mut r8[..n]]
}

/// [`EmbeddedRk::interpolate`] of [`Dop853`] from its coefficients `cont`
/// on a state of length `N` (as [`attempt_len`]): the eight rows cut from
/// one buffer with one bounds check (each sample's, where eight buffers
/// took eight).
#[inline(always)]
fn interpolate_len<const N: usize>(cont: &[f64], theta: f64, out: &mut [f64]) {
    let n = state_len::<N>(out.len());
    let out = &mut out[..n];
    let c = &cont[..8 * n];
    let (r1, c) = c.split_at(n);
    let (r2, c) = c.split_at(n);
    let (r3, c) = c.split_at(n);
    let (r4, c) = c.split_at(n);
    let (r5, c) = c.split_at(n);
    let (r6, c) = c.split_at(n);
    let (r7, r8) = c.split_at(n);
    let s = theta;
    let s1 = 1.0 - s;
    for i in 0..n {
        out[i] =
            r1[i] + s * (r2[i] + s1 * (r3[i] + s * (r4[i] + s1 * (r5[i] + s * (r6[i] + s1 * (r7[i] + s * r8[i]))))));
    }
}

/// Dormand-Prince 8(5,3) with its stage and dense-output buffers.
#[derive(Debug, Clone)]
pub struct Dop853 {
    /// Stages `k2..=k12` (index `i - 2` holds `k_i`) of the last attempt.
    k: [Vec<f64>; 11],
    /// Stages 14, 15, 16 of the dense output.
    kd: [Vec<f64>; 3],
    /// Stage argument.
    tmp: Vec<f64>,
    /// Dense output coefficients, HNW's `rcont1..8`, one row of `ny`
    /// after the other.
    cont: Vec<f64>,
}

impl EmbeddedRk for Dop853 {
    const ORDER: u32 = 8;
    const EXPONENT: f64 = 1.0 / 8.0;
    const BETA: f64 = 0.0;
    const FAC_MIN: f64 = 0.333;
    const FAC_MAX: f64 = 6.0;
    const STIFF_LIMIT: f64 = 6.1;
    const DENSE_EVALS: u64 = 3;
    /// Stages 2..=12; `F(t + h, y_new)` (Hairer's stage 13) is left to the
    /// caller, after acceptance and projection.
    const STAGE_EVALS: u64 = 11;
    const FSAL_IN_ESTIMATE: bool = false;

    fn stiffness(&self, h: f64, y_new: &[f64], k_new: &[f64]) -> f64 {
        super::adaptive::stiffness_quotient(h, y_new, &self.tmp, k_new, &self.k[10])
    }

    fn new(ny: usize) -> Self {
        let v = || vec![0.0; ny];
        Self { k: std::array::from_fn(|_| v()), kd: std::array::from_fn(|_| v()), tmp: v(), cont: vec![0.0; 8 * ny] }
    }

    fn attempt<R: Rhs>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        tol: &Tolerance,
        y_new: &mut [f64],
        _k_new: &mut [f64],
    ) -> Result<f64, SimError> {
        by_len!(y.len(), attempt_len::<_, R>(self, rhs, t, y, k1, h, tol, y_new))
    }

    fn error_vectors(&self, k1: &[f64], _h: f64, ea: &mut [f64], eb: &mut [f64]) {
        let n = ea.len();
        let [_, _, _, _, k6, k7, k8, k9, k10, k11, k12] = self.k.each_ref().map(|v| &v[..n]);
        for i in 0..n {
            (_, ea[i], eb[i]) = combinations([&k1[..n], k6, k7, k8, k9, k10, k11, k12], i);
        }
    }

    fn error_from(h: f64, ea: &[f64], eb: &[f64], y: &[f64], y_new: &[f64], tol: &Tolerance) -> f64 {
        let n = ea.len();
        if n == 0 {
            return 0.0;
        }
        let (mut err5, mut err3) = (0.0, 0.0);
        for i in 0..n {
            let sk = tol.scale(y[i], y_new[i]);
            err5 += (ea[i] / sk).powi(2);
            err3 += (eb[i] / sk).powi(2);
        }
        error_norm_853(h, err5, err3, n)
    }

    fn prepare_dense<R: Rhs>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        y_new: &[f64],
        k13: &[f64],
    ) -> Result<(), SimError> {
        by_len!(y.len(), prepare_dense_len::<_, R>(self, rhs, t, y, k1, h, y_new, k13))
    }

    fn interpolate(&self, theta: f64, out: &mut [f64]) {
        by_len!(out.len(), interpolate_len::<_>(&self.cont, theta, out))
    }
}

#[cfg(test)]
mod tests {
    use super::super::adaptive::{Controller, initial_step};
    use super::*;

    /// y' = (y1, -y0): y = (cos t, -sin t) from (1, 0).
    fn oscillator(_t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
    }

    fn exact(t: f64) -> [f64; 2] {
        [t.cos(), -t.sin()]
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    /// Kepler's problem `q'' = -q / |q|^3`: a nonlinear system, which
    /// exercises all elementary differentials (the oscillator, being
    /// linear, only checks the conditions `b A^k 1 = 1 / (k + 1)!`).
    fn kepler(_t: f64, y: &[f64], dy: &mut [f64]) {
        let r3 = (y[0] * y[0] + y[1] * y[1]).powf(1.5);
        dy[0] = y[2];
        dy[1] = y[3];
        dy[2] = -y[0] / r3;
        dy[3] = -y[1] / r3;
    }

    /// A nonautonomous problem, `y' = (1 + t) (y1, -y0)`: a rotation by
    /// `t + t^2 / 2` from (1, 0). It checks the stage times `t + c_i h`,
    /// which the autonomous problems ignore.
    fn rotation(t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = (1.0 + t) * y[1];
        dy[1] = -(1.0 + t) * y[0];
    }

    fn rotation_exact(t: f64) -> [f64; 2] {
        let phi = t + 0.5 * t * t;
        [phi.cos(), -phi.sin()]
    }

    /// Kepler's orbit of eccentricity `ecc` from its pericentre; period 2 pi.
    fn kepler_y0(ecc: f64) -> [f64; 4] {
        [1.0 - ecc, 0.0, 0.0, ((1.0 + ecc) / (1.0 - ecc)).sqrt()]
    }

    /// A right-hand side as a plain function.
    type Field = fn(f64, &[f64], &mut [f64]);

    const LOOSE: Tolerance = Tolerance { rtol: 1.0, atol: 1.0 };

    /// One attempt of size `h` from `(0, y0)`: `(stepper, k1, y_new, k_new, err)`.
    fn one_step(rhs: Field, y0: &[f64], h: f64, tol: &Tolerance) -> (Dop853, Vec<f64>, Vec<f64>, Vec<f64>, f64) {
        let ny = y0.len();
        let mut s = Dop853::new(ny);
        let mut rhs = rhs;
        let (mut k1, mut y_new, mut k_new) = (vec![0.0; ny], vec![0.0; ny], vec![0.0; ny]);
        rhs(0.0, y0, &mut k1);
        let err = s.attempt(&mut rhs, 0.0, y0, &k1, h, tol, &mut y_new, &mut k_new).unwrap();
        // the driver's part: F at the accepted state
        rhs(h, &y_new, &mut k_new);
        (s, k1, y_new, k_new, err)
    }

    /// `n` fixed steps of size `t_end / n` from `(0, y0)`; the final state.
    fn fixed_run(rhs: Field, y0: &[f64], t_end: f64, n: usize) -> Vec<f64> {
        let ny = y0.len();
        let mut s = Dop853::new(ny);
        let mut rhs = rhs;
        let h = t_end / n as f64;
        let (mut y, mut k1, mut y_new, mut k_new) = (y0.to_vec(), vec![0.0; ny], vec![0.0; ny], vec![0.0; ny]);
        rhs(0.0, &y, &mut k1);
        for i in 0..n {
            s.attempt(&mut rhs, i as f64 * h, &y, &k1, h, &LOOSE, &mut y_new, &mut k_new).unwrap();
            y.copy_from_slice(&y_new);
            rhs((i + 1) as f64 * h, &y, &mut k1);
        }
        y
    }

    /// Least-squares slope of `ln e` against `ln h`.
    fn fitted_order(hs: &[f64], es: &[f64]) -> f64 {
        let m = hs.len() as f64;
        let (lx, ly): (Vec<f64>, Vec<f64>) = hs.iter().zip(es).map(|(h, e)| (h.ln(), e.ln())).unzip();
        let mx = lx.iter().sum::<f64>() / m;
        let my = ly.iter().sum::<f64>() / m;
        lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
            / lx.iter().map(|x| (x - mx).powi(2)).sum::<f64>()
    }

    /// Fixed steps on [0, 4]: N = 6..24, i.e. h = 0.67..0.17 (errors
    /// 8e-9..1e-13; at N = 64 the error is already at roundoff, 4e-16).
    #[test]
    fn converges_with_order_eight_on_the_oscillator() {
        let ns = [6usize, 8, 12, 16, 24];
        let hs: Vec<f64> = ns.iter().map(|&n| 4.0 / n as f64).collect();
        let es: Vec<f64> =
            ns.iter().map(|&n| max_diff(&fixed_run(oscillator, &[1.0, 0.0], 4.0, n), &exact(4.0))).collect();
        let p = fitted_order(&hs, &es);
        assert!((p - 8.0).abs() <= 0.3, "fitted order {p}, errors {es:?}");
    }

    /// One period of a Kepler orbit (eccentricity 0.1) in N = 24..96 fixed
    /// steps (errors 4e-9..7e-14).
    #[test]
    fn converges_with_order_eight_on_kepler() {
        let y0 = kepler_y0(0.1);
        let ns = [24usize, 32, 48, 64, 96];
        let t_end = 2.0 * std::f64::consts::PI;
        let hs: Vec<f64> = ns.iter().map(|&n| t_end / n as f64).collect();
        let es: Vec<f64> = ns.iter().map(|&n| max_diff(&fixed_run(kepler, &y0, t_end, n), &y0)).collect();
        let p = fitted_order(&hs, &es);
        assert!((p - 8.0).abs() <= 0.3, "fitted order {p}, errors {es:?}");
    }

    /// Fixed steps on [0, 2] of the nonautonomous rotation, N = 6..24
    /// (errors 1e-7..2e-12).
    #[test]
    fn converges_with_order_eight_on_a_nonautonomous_problem() {
        let ns = [6usize, 8, 12, 16, 24];
        let hs: Vec<f64> = ns.iter().map(|&n| 2.0 / n as f64).collect();
        let es: Vec<f64> =
            ns.iter().map(|&n| max_diff(&fixed_run(rotation, &[1.0, 0.0], 2.0, n), &rotation_exact(2.0))).collect();
        let p = fitted_order(&hs, &es);
        assert!((p - 8.0).abs() <= 0.3, "fitted order {p}, errors {es:?}");
    }

    /// The combined estimate `|h| err5^2 / sqrt(err5^2 + 0.01 err3^2)` is
    /// `O(h^6)` while the order-5 part dominates and `O(h^8)` asymptotically;
    /// either way halving `h` divides it by far more than 2^5. It also
    /// overestimates the true local error (of order `h^9`).
    #[test]
    fn error_estimate_scales_with_the_step() {
        let tol = Tolerance { rtol: 1e-6, atol: 1e-6 };
        let y0 = [1.0, 0.0];
        let hs = [0.8, 0.4, 0.2, 0.1];
        let mut errs = vec![];
        for &h in &hs {
            let (_, _, y_new, _, err) = one_step(oscillator, &y0, h, &tol);
            let ex = exact(h);
            let true_err =
                ((0..2).map(|i| ((y_new[i] - ex[i]) / tol.scale(y0[i], y_new[i])).powi(2)).sum::<f64>() / 2.0).sqrt();
            assert!(err > true_err, "h {h}: estimate {err:e} below the true error {true_err:e}");
            errs.push(err);
        }
        for w in errs.windows(2) {
            assert!(w[0] / w[1] > 32.0, "estimates {errs:?}");
        }
        let p = fitted_order(&hs, &errs);
        assert!((p - 8.0).abs() <= 0.5, "estimate ~ h^{p}: {errs:?}");
        // on a nonlinear problem too
        let y0 = kepler_y0(0.5);
        let errs: Vec<f64> = [0.1, 0.05, 0.025].iter().map(|&h| one_step(kepler, &y0, h, &tol).4).collect();
        for w in errs.windows(2) {
            assert!(w[0] / w[1] > 32.0, "kepler estimates {errs:?}");
        }
    }

    #[test]
    fn adaptive_run_meets_its_tolerance() {
        for tolv in [1e-6, 1e-9, 1e-12] {
            let tol = Tolerance { rtol: tolv, atol: tolv };
            let mut s = Dop853::new(2);
            let mut rhs = oscillator;
            let mut ctl = Controller::default();
            let (mut y, mut k1, mut y_new, mut k_new) = (vec![1.0, 0.0], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
            let (mut w1, mut w2) = (vec![0.0; 2], vec![0.0; 2]);
            oscillator(0.0, &y, &mut k1);
            let mut h = initial_step(&mut rhs, 0.0, &y, &k1, Dop853::ORDER, &tol, 10.0, &mut w1, &mut w2).unwrap();
            let (mut t, t_end) = (0.0, 10.0);
            let (mut steps, mut rejected) = (0, 0);
            while t < t_end {
                h = h.min(t_end - t);
                let err = s.attempt(&mut rhs, t, &y, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
                let (ok, h_next) = ctl.next::<Dop853>(err, h);
                if ok {
                    t += h;
                    y.copy_from_slice(&y_new);
                    oscillator(t, &y, &mut k1);
                    steps += 1;
                } else {
                    rejected += 1;
                }
                assert!(steps + rejected < 10_000, "tol {tolv}: no progress at t = {t}, h = {h}");
                h = h_next;
            }
            let e = max_diff(&y, &exact(t_end));
            assert!(e <= 10.0 * tolv, "tol {tolv}: error {e} after {steps} steps ({rejected} rejected)");
        }
    }

    /// One step of h = 0.5 on the oscillator. The interpolant reproduces
    /// both ends; inside, it is a polynomial of order 7, so its error is
    /// O(h^8): the first Taylor term it does not match is h^8 / 8! = 9.7e-8
    /// here, and the bound is a tenth of that (measured: 5.0e-10 at
    /// theta = 0.3, 1.7e-9 at 0.7, the same to the last digit as SciPy's
    /// DOP853). A Hermite cubic alone (rcont1..4) would be off by ~1e-4,
    /// so the bound checks the stages 14..16 and the d coefficients.
    #[test]
    fn dense_output_reproduces_the_step() {
        let h = 0.5;
        let y0 = [1.0, 0.0];
        let (mut s, k1, y_new, k_new, _) = one_step(oscillator, &y0, h, &LOOSE);
        let mut rhs = oscillator;
        s.prepare_dense(&mut rhs, 0.0, &y0, &k1, h, &y_new, &k_new).unwrap();
        let mut out = vec![0.0; 2];
        s.interpolate(0.0, &mut out);
        assert!(max_diff(&out, &y0) <= 1e-15, "theta 0: {out:?}");
        s.interpolate(1.0, &mut out);
        assert!(max_diff(&out, &y_new) <= 1e-15, "theta 1: {out:?} vs {y_new:?}");
        for theta in [0.3, 0.7] {
            s.interpolate(theta, &mut out);
            let direct = one_step(oscillator, &y0, theta * h, &LOOSE).2;
            let (e_exact, e_direct) = (max_diff(&out, &exact(theta * h)), max_diff(&out, &direct));
            assert!(
                e_exact <= 1e-8 && e_direct <= 1e-8,
                "theta {theta}: {e_exact:e} from exact, {e_direct:e} from a step"
            );
        }
    }

    /// The dense output's local error is O(h^8) on a nonlinear and on a
    /// nonautonomous problem: halving h divides its distance from a direct
    /// step of theta h (error O(h^9)) by ~2^8 (measured 229..396); require
    /// 2^7.
    #[test]
    fn dense_output_has_order_seven() {
        let problems: [(Field, Vec<f64>); 2] = [(kepler, kepler_y0(0.1).to_vec()), (rotation, vec![1.0, 0.0])];
        for (f, y0) in problems {
            let mut rhs = f;
            let mut out = vec![0.0; y0.len()];
            for theta in [0.3, 0.5, 0.7] {
                let es: Vec<f64> = [0.4, 0.2, 0.1]
                    .iter()
                    .map(|&h| {
                        let (mut s, k1, y_new, k_new, _) = one_step(f, &y0, h, &LOOSE);
                        s.prepare_dense(&mut rhs, 0.0, &y0, &k1, h, &y_new, &k_new).unwrap();
                        s.interpolate(theta, &mut out);
                        max_diff(&out, &one_step(f, &y0, theta * h, &LOOSE).2)
                    })
                    .collect();
                for w in es.windows(2) {
                    assert!(w[0] / w[1] > 128.0, "y0 {y0:?}, theta {theta}: {es:?}");
                }
            }
        }
    }

    /// Reference values from SciPy 1.17.1's independent implementation
    /// (`scipy.integrate.DOP853`: `rk_step`, `_estimate_error_norm` and the
    /// dense output) for one step h = 0.1 of Kepler's problem with
    /// eccentricity 0.5 and rtol = atol = 1e-6. The error norm is a sum with
    /// cancellation (err5 ~ 2e-8 from terms of size 1), so it agrees to a
    /// relative 1e-6 only.
    #[test]
    fn matches_scipy() {
        let tol = Tolerance { rtol: 1e-6, atol: 1e-6 };
        let (h, y0) = (0.1, kepler_y0(0.5));
        let (mut s, k1, y_new, k_new, err) = one_step(kepler, &y0, h, &tol);
        let y_ref = [0.4803249729065918, 0.17094505172953298, -0.38716324004300673, 1.6652096160205934];
        assert!(max_diff(&y_new, &y_ref) <= 1e-14, "{y_new:?}");
        let err_ref = 0.0019162623336222934;
        assert!((err / err_ref - 1.0).abs() <= 1e-6, "{err} vs {err_ref}");
        let mut rhs = kepler;
        s.prepare_dense(&mut rhs, 0.0, &y0, &k1, h, &y_new, &k_new).unwrap();
        let mut out = vec![0.0; 4];
        s.interpolate(0.5, &mut out);
        let dense_ref = [0.49502069926348846, 0.08631544161994828, -0.19834933121578768, 1.7148874682118898];
        assert!(max_diff(&out, &dense_ref) <= 1e-14, "{out:?}");
    }

    /// An attempt costs the 11 stages 2..=12 and leaves `k_new` alone
    /// (the driver evaluates `F(t + h, y_new)` after acceptance); the
    /// dense output 3 more.
    #[test]
    fn counts_its_evaluations() {
        let mut calls = 0u64;
        let mut rhs = |t: f64, y: &[f64], dy: &mut [f64]| {
            calls += 1;
            kepler(t, y, dy);
        };
        let y0 = kepler_y0(0.3);
        let (h, tol) = (0.05, Tolerance { rtol: 1e-6, atol: 1e-6 });
        let mut s = Dop853::new(4);
        let (mut k1, mut y_new, mut k_new) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 4]);
        kepler(0.0, &y0, &mut k1);
        s.attempt(&mut rhs, 0.0, &y0, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
        assert_eq!(k_new, [0.0; 4], "attempt wrote k_new");
        kepler(h, &y_new, &mut k_new);
        s.prepare_dense(&mut rhs, 0.0, &y0, &k1, h, &y_new, &k_new).unwrap();
        assert_eq!(calls, Dop853::STAGE_EVALS + Dop853::DENSE_EVALS);
        let mut s2 = Dop853::new(4);
        let mut calls2 = 0u64;
        let mut rhs2 = |t: f64, y: &[f64], dy: &mut [f64]| {
            calls2 += 1;
            kepler(t, y, dy);
        };
        s2.attempt(&mut rhs2, 0.0, &y0, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
        assert_eq!(calls2, Dop853::STAGE_EVALS);
        assert_eq!(Dop853::STAGE_EVALS, 11);
    }

    /// A step, its dense output and an interpolated state are the same,
    /// bit for bit, whether the state's length is a compile-time constant
    /// (`by_len!`: 1 to 12) or read at run time (`N = 0`, what every
    /// other length runs), for every length from 1 to 15: a linear system
    /// coupling each component to its neighbours, nonautonomous, so that
    /// every stage's argument and time enter.
    #[test]
    fn fixed_lengths_match_the_run_time_length() {
        fn chain(t: f64, y: &[f64], dy: &mut [f64]) {
            let n = y.len();
            for i in 0..n {
                let (l, r) = (y[(i + n - 1) % n], y[(i + 1) % n]);
                dy[i] = (1.0 + 0.1 * t) * (r - l) - 0.05 * (i as f64 + 1.0) * y[i];
            }
        }
        let tol = Tolerance { rtol: 1e-9, atol: 1e-9 };
        let h = 0.2;
        for n in 1..=15 {
            let y0: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin() + 0.1).collect();
            let mut k1 = vec![0.0; n];
            chain(0.3, &y0, &mut k1);
            let run = |fixed: bool| {
                let mut s = Dop853::new(n);
                let mut rhs = chain;
                let (mut y_new, mut k_new, mut out) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                let err = if fixed {
                    s.attempt(&mut rhs, 0.3, &y0, &k1, h, &tol, &mut y_new, &mut k_new).unwrap()
                } else {
                    attempt_len::<0, _>(&mut s, &mut rhs, 0.3, &y0, &k1, h, &tol, &mut y_new).unwrap()
                };
                chain(0.3 + h, &y_new, &mut k_new);
                if fixed {
                    s.prepare_dense(&mut rhs, 0.3, &y0, &k1, h, &y_new, &k_new).unwrap();
                    s.interpolate(0.37, &mut out);
                } else {
                    prepare_dense_len::<0, _>(&mut s, &mut rhs, 0.3, &y0, &k1, h, &y_new, &k_new).unwrap();
                    interpolate_len::<0>(&s.cont, 0.37, &mut out);
                }
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                (err.to_bits(), bits(&y_new), bits(&out), bits(&s.cont))
            };
            let (fixed, dynamic) = (run(true), run(false));
            assert_eq!(fixed, dynamic, "length {n}");
            // the step did something
            assert!(f64::from_bits(fixed.0) > 0.0, "length {n}: zero error estimate");
        }
    }
}
