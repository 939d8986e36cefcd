"""Model.tool_compliance / stiffness on the tree model of the chain
(Model.tree_model, robot/model_tree.py; TreeModel.compliance, core/sk_tree_point.f90)
against the numbers of the serial-chain code it replaced (core/sk_chain.f90's
spring Jacobians, before issue 15's one model), 1e-9 relative: five models
of the KR-270-like robot (joints, links, base, tool, compensator, profile;
a rank-3 wrist; a rigid robot; a tool spring alone) at two postures."""

from __future__ import annotations

import numpy as np
import pytest
from _calib_util import data, joints_truth, spd

from stiffkit.calib import synth as S
from stiffkit.robot.model import SPRING_JOINT, SYM, model_from_tables

RTOL = 1e-9
Q = np.array([[0.3, -0.7, 0.4, 1.1, 0.9, -0.5], [-1.2, -0.2, 0.9, -2.0, 1.5, 2.2]])


def cases() -> dict[str, list[dict]]:
    return {
        "full": S.kr270_truth(compensator=True)
        + [
            {"kind": "joint_profile", "target": "joint_a3", "value": [0, 1e-7, -5e-8, 3e-8, 2e-8]},
            {"kind": "base", "value": spd(1).tolist()},
            {"kind": "tool", "value": spd(2).tolist()},
        ],
        "joints": joints_truth(),
        "wrist": [
            {"kind": "joint", "target": j, "value": c}
            for j, c in (("joint_a4", 1.5e-6), ("joint_a5", 1.6e-6), ("joint_a1", 3e-7))
        ],
        "rigid": [],
        "tool_only": [{"kind": "tool", "value": spd(2).tolist()}],
    }


#: the upper triangle (robot.model.SYM order) of C at the two postures Q, by the former sk_chain code
# fmt: off
REF_C = {
    "full": [
        [3.0295015709274002e-06, -2.7717270940101376e-06, -2.6730269412473076e-06, 1.2619933944027475e-07,
         1.252435691360334e-06, -1.4304503953189215e-06, 5.524210345071468e-06, 5.927341016270533e-07,
         -5.110675680722612e-07, -3.41876984405688e-07, 2.344196057480578e-06, 4.3476654418079765e-06,
         6.901051954156885e-07, -2.2158896082275235e-06, 2.619384651710116e-07, 3.3290750533775108e-06,
         1.033045527357611e-06, -4.325541179520929e-07, 4.05727929789164e-06, 2.0970589938561222e-07,
         2.9866309955254885e-06],
        [4.6843134654292765e-06, 1.2198800577912536e-06, 3.4557791245188657e-07, -6.965704549161335e-08,
         -3.841276148997425e-07, 2.3659582169895453e-06, 7.546288132514705e-07, -3.1058461353692436e-07,
         2.8166714638405885e-07, -2.0787010175077997e-08, 3.253366688433221e-07, 3.485879906011937e-06,
         -1.8214060685029504e-06, -6.187543743250452e-07, 1.3670487587228962e-07, 3.6122949282095766e-06,
         5.318051092996073e-07, -1.393655666478448e-07, 3.5888699002744833e-06, -2.0639731772349748e-07,
         3.1039542673735624e-06],
    ],
    "joints": [
        [5.461129180967979e-07, -5.729021143513398e-07, -5.723367086830398e-07, -7.560658719691157e-08,
         1.744292569564253e-07, -5.287199670952385e-07, 1.7054357401008944e-06, -1.8132628680704918e-07,
         9.152905359702314e-09, 1.5873680638589538e-07, 8.312259936972529e-07, 1.481080131663647e-06,
         5.045358784070485e-07, -7.821696324032077e-07, -8.313021918898387e-08, 2.063142597686325e-06,
         1.0333502034372511e-06, -3.0041338753498927e-07, 2.685397875232494e-06, 2.693418041566956e-07,
         1.651459527081181e-06],
        [1.7729653848007263e-06, 4.231566880855324e-07, 1.5839313648673951e-07, -8.541890712214028e-08,
         5.396988308800884e-08, 9.207594072208793e-07, 3.5738225792740877e-07, -3.61039980097891e-07,
         1.5396545761745698e-07, 1.0041394518445069e-07, -2.6010775161622107e-08, 1.2904370607713033e-06,
         -8.81652124307875e-07, -1.5374364610440074e-08, -1.499503806231045e-08, 2.4539486791083728e-06,
         6.379996532532554e-07, -9.550609931439446e-08, 2.0647930852090116e-06, -1.7802047927798625e-07,
         1.8812582356826155e-06],
    ],
    "wrist": [
        [2.892368654102334e-07, -6.523631891039257e-07, 1.5628894229209908e-08, 1.7086215776347767e-08,
         -1.252213759397705e-07, -5.287199670952385e-07, 1.6808555492469796e-06, 5.5278769728711e-10,
         3.782614939725399e-08, 6.604400341263602e-08, 8.312259936972529e-07, 4.9394047332551935e-08,
         2.6274605709039793e-07, -5.28872156761476e-10, -8.313021918898381e-08, 1.4874096886050934e-06,
         1.6713489834731995e-07, -1.2078686497966588e-07, 3.2177295711716624e-07, 6.094333672407583e-07,
         1.5908173542777403e-06],
        [1.7491459036583617e-06, 4.844240051440726e-07, 1.2584351819884517e-08, 1.452468142578447e-08,
         9.282590840478413e-08, 9.207594072208793e-07, 1.9979342897195714e-07, 1.4002321903227222e-08,
         -1.0310460578721271e-07, 4.70356636526054e-10, -2.6010775161622117e-08, 6.608778589477603e-08,
         -1.9931513690912697e-07, 2.499043155144436e-07, -1.499503806231055e-08, 6.914630363045388e-07,
         -6.758064299491532e-07, 3.9997983647748486e-07, 1.0121288398798376e-06, 2.491204848576101e-07,
         1.6964081238156232e-06],
    ],
    "tool_only": [
        [4.2067962143648805e-08, -9.621451095732559e-09, 2.2964069706216067e-08, -3.652824973192031e-09,
         1.4045499133125251e-08, -1.0578158433009673e-09, 2.7989719463537213e-08, -9.7699861191329e-09,
         -1.549978344724154e-08, 4.134852951032125e-09, -1.2278116418312894e-09, 4.8689698947682005e-08,
         -9.2796625151726e-09, 2.5854878457667495e-08, 2.4414236405704018e-08, 3.509370388333785e-07,
         -1.2888448165512866e-07, -1.730964521838415e-07, 2.601038465096405e-07, 6.175660487746661e-08,
         2.9471652375255915e-07],
        [2.382071799304372e-08, 2.883506157315378e-09, 9.445376227177282e-09, 7.997018268556912e-09,
         -9.920098168195936e-09, 1.4146288807786412e-08, 2.8450886076520657e-08, 1.3483390704980515e-08,
         -1.0885896744962907e-08, 1.0889746685871187e-08, 7.1660084903110735e-09, 6.647577648530369e-08,
         6.573749099434333e-09, -3.302999210613545e-08, 6.009499429116001e-09, 3.66423174102253e-07,
         -1.775890478518363e-07, -4.79205105686203e-09, 3.9469097387596376e-07, 4.6654780536490816e-08,
         1.4464326111736147e-07],
    ],
}
# fmt: on
#: K = C^-1 of the "full" model at Q (upper triangle), by the former sk_chain code
# fmt: off
REF_K_FULL = [
    [3971917.587992426, 1544744.0361856867, 2467067.9330886547, -486080.0272169326, 355690.24607924774,
     378145.7963562583, 877464.4412403796, 945804.0018178804, -179467.55872346426, 162919.17674972228,
     -69243.89369073384, 1931421.4178866593, -477897.4340256854, 486062.8477607825, 166511.3558406522,
     471955.376913323, -248093.93670384897, 35741.44276811622, 482649.9151955026, -69966.58906184627,
     565773.5604989677],
    [700191.4497935902, -1007829.2199538259, -137119.87307177938, 3671.652464433064, 20738.443291227653,
     -420496.81930508045, 2914991.75771566, 301442.0857880154, -77251.5006513683, -1930.1308597117732,
     445803.90720979666, 429237.0158787299, 187332.2555440916, 37046.850307691995, 64893.0211337039,
     381335.899289636, -23538.794271486797, 12604.337288309172, 290782.91445080395, 1041.7302773138538,
     593740.0543042297],
]
# fmt: on
RANK = {"full": [6, 6], "joints": [6, 6], "wrist": [3, 3], "rigid": [0, 0], "tool_only": [6, 6]}


def _sym(upper: list[float]) -> np.ndarray:
    m = np.zeros((6, 6))
    for (a, b), v in zip(SYM, upper):
        m[a, b] = m[b, a] = v
    return m


def _close(got: np.ndarray, want: np.ndarray) -> None:
    scale = np.abs(want).max()
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=RTOL * 1e-3 * scale)


@pytest.fixture(scope="module")
def chain():
    return data(joints_truth(), n_configs=1)[0]


@pytest.mark.parametrize("name", sorted(cases()))
def test_tree_route_gives_the_former_chain_numbers(chain, name):
    C, K, rank, ok = model_from_tables(chain, cases()[name]).stiffness(Q)
    assert rank.tolist() == RANK[name]
    np.testing.assert_array_equal(ok, np.array(RANK[name]) == 6)
    if name == "rigid":
        assert not C.any() and not K.any()
        return
    _close(C, np.array([_sym(u) for u in REF_C[name]]))
    if name == "full":
        _close(K, np.array([_sym(u) for u in REF_K_FULL]))
    else:
        assert ok.all() or not K.any()  # no stiffness where C is singular


@pytest.mark.parametrize("name", sorted(cases()))
def test_compliance_is_the_sum_of_the_springs_terms(chain, name):
    """Model.tool_compliance (TreeModel.compliance of the chain's TreeModel,
    one core loop) equals sum_s J_s C_s J_s^T with the springs' Jacobians
    Model.jacobians (TreeModel.twists), posture by posture. (The core's own
    chain tree model, the deflection rows', agrees with it:
    test_calib_model.py test_basis_prediction_matches_tool_compliance.)"""
    m = model_from_tables(chain, cases()[name])
    C = m.tool_compliance(Q)
    jc = m.joint_compliances(Q)
    six = m.six_values()
    for n, q in enumerate(Q):
        ref = np.zeros((6, 6))
        for (stype, k), J in m.jacobians(q).items():
            ref += jc[k - 1][n] * J @ J.T if stype == SPRING_JOINT else J @ six[(stype, k)] @ J.T
        np.testing.assert_allclose(C[n], ref, rtol=1e-12, atol=1e-12 * (np.abs(ref).max() + 1e-300))


def test_tree_compliance_refuses_an_unknown_frame_and_bad_postures(chain):
    from stiffkit.errors import InputError

    tm = model_from_tables(chain, cases()["joints"]).tree_model().model
    with pytest.raises(InputError, match="unknown frame 'nowhere'"):
        tm.compliance(Q, "nowhere")
    with pytest.raises(InputError, match=r"postures must have shape \(N, 6\)"):
        tm.compliance(np.zeros((2, 5)), chain.tool_frame)
