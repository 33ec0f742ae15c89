"""``dop853``: the Dormand-Prince 8(5,3) pair of Hairer's DOP853, compiled (``integrators.embedded_rk``).

Order 8 with 12 stages per step attempt (the 13th, f(t + h, y_new), is the next step's first), error estimated
from the embedded 5th-order solution and corrected with the 3rd-order one (Hairer, Nørsett & Wanner, Solving
ODEs I, §II.10), controller exponent −1/8 (scipy's ``error_estimator_order`` = 7). Dense output of order 7
with three extra stages per step that needs it. Coefficients: Hairer's dop853.f (http://www.unige.ch/~hairer/
software.html), as in scipy's ``dop853_coefficients.py``; its dense output (``CONTD8``: y_old + θ(F₀ + (1 − θ)
(F₁ + θ(F₂ + …)))) is expanded here into weights bᵢ(θ), so the tableau validates it like the others.

Tolerance mapping: rtol = tol, atol = tol × (R, R, kR, kR) (``integrators.adaptive``), as for ``scipy_dop853``,
whose steps this integrator reproduces exactly (same nfev, same accepted steps), in compiled code.

Stability: explicit, bounded stability region (reaching about 6 along the imaginary axis); on the pendulum the
steps are accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

STAGES = 12
EXTENDED_STAGES = 16

NODES = (  # c of the 12 stages, the FSAL stage and the 3 dense-output stages
    0.0, 0.526001519587677318785587544488e-01, 0.789002279381515978178381316732e-01, 0.118350341907227396726757197510,
    0.281649658092772603273242802490, 0.333333333333333333333333333333, 0.25, 0.307692307692307692307692307692,
    0.651282051282051282051282051282, 0.6, 0.857142857142857142857142857142, 1.0, 1.0, 0.1, 0.2,
    0.777777777777777777777777777778,
)
# a by row: {column: aᵢⱼ} for the non-zero entries; rows 0-11 the method, 12 the FSAL stage (= b), 13-15 dense output
COUPLING: dict[int, dict[int, float]] = {
    1: {
        0: 5.26001519587677318785587544488e-2,
    },
    2: {
        0: 1.97250569845378994544595329183e-2, 1: 5.91751709536136983633785987549e-2,
    },
    3: {
        0: 2.95875854768068491816892993775e-2, 2: 8.87627564304205475450678981324e-2,
    },
    4: {
        0: 2.41365134159266685502369798665e-1, 2: -8.84549479328286085344864962717e-1,
        3: 9.24834003261792003115737966543e-1,
    },
    5: {
        0: 3.7037037037037037037037037037e-2, 3: 1.70828608729473871279604482173e-1,
        4: 1.25467687566822425016691814123e-1,
    },
    6: {
        0: 3.7109375e-2, 3: 1.70252211019544039314978060272e-1, 4: 6.02165389804559606850219397283e-2,
        5: -1.7578125e-2,
    },
    7: {
        0: 3.70920001185047927108779319836e-2, 3: 1.70383925712239993810214054705e-1,
        4: 1.07262030446373284651809199168e-1, 5: -1.53194377486244017527936158236e-2,
        6: 8.27378916381402288758473766002e-3,
    },
    8: {
        0: 6.24110958716075717114429577812e-1, 3: -3.36089262944694129406857109825,
        4: -8.68219346841726006818189891453e-1, 5: 2.75920996994467083049415600797e1,
        6: 2.01540675504778934086186788979e1, 7: -4.34898841810699588477366255144e1,
    },
    9: {
        0: 4.77662536438264365890433908527e-1, 3: -2.48811461997166764192642586468,
        4: -5.90290826836842996371446475743e-1, 5: 2.12300514481811942347288949897e1,
        6: 1.52792336328824235832596922938e1, 7: -3.32882109689848629194453265587e1,
        8: -2.03312017085086261358222928593e-2,
    },
    10: {
        0: -9.3714243008598732571704021658e-1, 3: 5.18637242884406370830023853209, 4: 1.09143734899672957818500254654,
        5: -8.14978701074692612513997267357, 6: -1.85200656599969598641566180701e1,
        7: 2.27394870993505042818970056734e1, 8: 2.49360555267965238987089396762, 9: -3.0467644718982195003823669022,
    },
    11: {
        0: 2.27331014751653820792359768449, 3: -1.05344954667372501984066689879e1,
        4: -2.00087205822486249909675718444, 5: -1.79589318631187989172765950534e1,
        6: 2.79488845294199600508499808837e1, 7: -2.85899827713502369474065508674,
        8: -8.87285693353062954433549289258, 9: 1.23605671757943030647266201528e1,
        10: 6.43392746015763530355970484046e-1,
    },
    12: {
        0: 5.42937341165687622380535766363e-2, 5: 4.45031289275240888144113950566, 6: 1.89151789931450038304281599044,
        7: -5.8012039600105847814672114227, 8: 3.1116436695781989440891606237e-1,
        9: -1.52160949662516078556178806805e-1, 10: 2.01365400804030348374776537501e-1,
        11: 4.47106157277725905176885569043e-2,
    },
    13: {
        0: 5.61675022830479523392909219681e-2, 6: 2.53500210216624811088794765333e-1,
        7: -2.46239037470802489917441475441e-1, 8: -1.24191423263816360469010140626e-1,
        9: 1.5329179827876569731206322685e-1, 10: 8.20105229563468988491666602057e-3,
        11: 7.56789766054569976138603589584e-3, 12: -8.298e-3,
    },
    14: {
        0: 3.18346481635021405060768473261e-2, 5: 2.83009096723667755288322961402e-2,
        6: 5.35419883074385676223797384372e-2, 7: -5.49237485713909884646569340306e-2,
        10: -1.08347328697249322858509316994e-4, 11: 3.82571090835658412954920192323e-4,
        12: -3.40465008687404560802977114492e-4, 13: 1.41312443674632500278074618366e-1,
    },
    15: {
        0: -4.28896301583791923408573538692e-1, 5: -4.69762141536116384314449447206,
        6: 7.68342119606259904184240953878, 7: 4.06898981839711007970213554331, 8: 3.56727187455281109270669543021e-1,
        12: -1.39902416515901462129418009734e-3, 13: 2.9475147891527723389556272149,
        14: -9.15095847217987001081870187138,
    },
}
DENSE_D: dict[int, dict[int, float]] = {  # rows F₃…F₆ of the dense output over the 16 stages
    0: {
        0: -0.84289382761090128651353491142e+1, 5: 0.56671495351937776962531783590,
        6: -0.30689499459498916912797304727e+1, 7: 0.23846676565120698287728149680e+1,
        8: 0.21170345824450282767155149946e+1, 9: -0.87139158377797299206789907490,
        10: 0.22404374302607882758541771650e+1, 11: 0.63157877876946881815570249290,
        12: -0.88990336451333310820698117400e-1, 13: 0.18148505520854727256656404962e+2,
        14: -0.91946323924783554000451984436e+1, 15: -0.44360363875948939664310572000e+1,
    },
    1: {
        0: 0.10427508642579134603413151009e+2, 5: 0.24228349177525818288430175319e+3,
        6: 0.16520045171727028198505394887e+3, 7: -0.37454675472269020279518312152e+3,
        8: -0.22113666853125306036270938578e+2, 9: 0.77334326684722638389603898808e+1,
        10: -0.30674084731089398182061213626e+2, 11: -0.93321305264302278729567221706e+1,
        12: 0.15697238121770843886131091075e+2, 13: -0.31139403219565177677282850411e+2,
        14: -0.93529243588444783865713862664e+1, 15: 0.35816841486394083752465898540e+2,
    },
    2: {
        0: 0.19985053242002433820987653617e+2, 5: -0.38703730874935176555105901742e+3,
        6: -0.18917813819516756882830838328e+3, 7: 0.52780815920542364900561016686e+3,
        8: -0.11573902539959630126141871134e+2, 9: 0.68812326946963000169666922661e+1,
        10: -0.10006050966910838403183860980e+1, 11: 0.77771377980534432092869265740,
        12: -0.27782057523535084065932004339e+1, 13: -0.60196695231264120758267380846e+2,
        14: 0.84320405506677161018159903784e+2, 15: 0.11992291136182789328035130030e+2,
    },
    3: {
        0: -0.25693933462703749003312586129e+2, 5: -0.15418974869023643374053993627e+3,
        6: -0.23152937917604549567536039109e+3, 7: 0.35763911791061412378285349910e+3,
        8: 0.93405324183624310003907691704e+2, 9: -0.37458323136451633156875139351e+2,
        10: 0.10409964950896230045147246184e+3, 11: 0.29840293426660503123344363579e+2,
        12: -0.43533456590011143754432175058e+2, 13: 0.96324553959188282948394950600e+2,
        14: -0.39177261675615439165231486172e+2, 15: -0.14972683625798562581422125276e+3,
    },
}
ERROR_5: dict[int, float] = {  # e of the 5th-order estimate (scipy's E5)
    0: 0.1312004499419488073250102996e-1, 5: -0.1225156446376204440720569753e+1, 6: -0.4957589496572501915214079952,
    7: 0.1664377182454986536961530415e+1, 8: -0.3503288487499736816886487290, 9: 0.3341791187130174790297318841,
    10: 0.8192320648511571246570742613e-1, 11: -0.2235530786388629525884427845e-1,
}
WEIGHTS_3: dict[int, float] = {  # the 3rd-order solution b̂ (E3 = b − b̂)
    0: 0.244094488188976377952755905512, 8: 0.733846688281611857341361741547, 11: 0.220588235294117647058823529412e-1,
}


def _row(entries: dict[int, float], length: int) -> tuple[float, ...]:
    return tuple(float(entries.get(j, 0.0)) for j in range(length))


def _expand_hairer_dense_output(b: np.ndarray) -> tuple[tuple[float, ...], ...]:
    """Weights P (16 × 7) with bᵢ(θ) = Σₘ Pᵢₘ θ^(m+1) equal to Hairer's CONTD8 form
    y_old + θ(F₀ + (1−θ)(F₁ + θ(F₂ + (1−θ)(F₃ + θ(F₄ + (1−θ)(F₅ + θF₆)))))) with F₀ = Δy = hΣbᵢkᵢ,
    F₁ = hk₁ − Δy, F₂ = 2Δy − h(k₁ + k₁₃) and F₃…F₆ = hΣDᵢkᵢ."""
    combinations = np.zeros((7, EXTENDED_STAGES))
    combinations[0, :STAGES] = b
    combinations[1, :STAGES] = -b
    combinations[1, 0] += 1.0
    combinations[2, :STAGES] = 2.0 * b
    combinations[2, 0] -= 1.0
    combinations[2, STAGES] -= 1.0
    for row, entries in DENSE_D.items():
        combinations[3 + row] = _row(entries, EXTENDED_STAGES)
    weights = np.zeros((EXTENDED_STAGES, 8))
    theta, one_minus = np.polynomial.Polynomial([0.0, 1.0]), np.polynomial.Polynomial([1.0, -1.0])
    multiplier = np.polynomial.Polynomial([1.0])
    for index in range(7):  # Fᵢ is multiplied by θ^⌈(i+1)/2⌉ (1 − θ)^⌊(i+1)/2⌋
        multiplier = multiplier * (theta if index % 2 == 0 else one_minus)
        coefficients = np.zeros(8)
        coefficients[: multiplier.coef.size] = multiplier.coef
        weights += np.outer(combinations[index], coefficients)
    return tuple(tuple(row[1:]) for row in weights)


_B = np.array(_row(COUPLING[STAGES], STAGES))

TABLEAU = ButcherTableau(
    name="dop853",
    c=tuple(float(x) for x in NODES[:STAGES]),
    a=tuple(_row(COUPLING.get(i, {}), STAGES) for i in range(STAGES)),
    b=tuple(_B),
    order=8,
    error_weights=_row(ERROR_5, STAGES + 1),
    error_order=5,
    secondary_error_weights=tuple(np.concatenate([_B, [0.0]]) - np.array(_row(WEIGHTS_3, STAGES + 1))),
    secondary_error_order=3,
    dense_c=tuple(float(x) for x in NODES[STAGES + 1:]),
    dense_a=tuple(_row(COUPLING[i], EXTENDED_STAGES) for i in range(STAGES + 1, EXTENDED_STAGES)),
    dense_weights=_expand_hairer_dense_output(_B),
    dense_order=7,
    reference="Hairer, Nørsett & Wanner, Solving ODEs I, §II.10 (DOP853); Dormand & Prince, J. Comput. Appl. "
              "Math. 35, 67 (1991)",
)


@register
class Dop853(EmbeddedRungeKutta):
    """DOP853 with scipy's error norm, controller and initial step, compiled: the steps of ``scipy_dop853``."""

    name: ClassVar[str] = "dop853"
    tableau: ClassVar[ButcherTableau] = TABLEAU
    reference: ClassVar[str] = TABLEAU.reference
