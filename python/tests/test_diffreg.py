"""Tests of the Python module: the same results as the diffreg tool, the shipped meshes, the
error messages and the session reuse counters (run by ctest as python_diffreg)."""
import json
import os
import subprocess
import sys
import threading
import time
import _thread
import warnings

import numpy as np
import pytest

import diffreg

SOURCE = os.environ.get(
    "DIFFREG_SOURCE_DIR",
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
TOOL = os.environ.get("DIFFREG_TOOL", os.path.join(os.getcwd(), "diffreg"))
MESHES = os.path.join(SOURCE, "meshes")
SCENARIOS = [("bar.obj", "bar-bend.json"), ("cylinder.obj", "cylinder-twist.json"),
             ("tetbar.mesh", "tetbar-bend.json"), ("disc.obj", "disc-drag.json"),
             ("lshape.obj", "lshape-bend.json"), ("ushape.obj", "ushape-pull.json")]


def mesh(name):
    return os.path.join(MESHES, name)


def scenario(mesh_name, handles_name):
    V, E = diffreg.read_mesh(mesh(mesh_name))
    handles, targets, ranges, magnitudes, names = diffreg.read_handles(mesh(handles_name), V, E)
    return V, E, handles, targets, ranges, magnitudes


def square():
    """Two triangles of the unit square (planar)."""
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    E = np.array([[0, 1, 2], [0, 2, 3]])
    return V, E


# ---- the same results as the tool --------------------------------------------------------------

@pytest.fixture(scope="module")
def cli_bar(tmp_path_factory):
    if not os.path.exists(TOOL):
        pytest.skip("the diffreg tool is not built")
    out = tmp_path_factory.mktemp("cli")
    om, report = str(out / "bar.om"), str(out / "report.json")
    subprocess.run([TOOL, "-i", mesh("bar.obj"), "--handles", mesh("bar-bend.json"),
                    "--filter", "diffuse_weights t=0.01",
                    "--filter", "deform energy=arap regularization=nonuniform",
                    "--filter", "measure", "-o", om, "--report", report, "--quiet"],
                   check=True)
    with open(report) as f:
        return om, json.load(f)


def test_weights_and_positions_equal_the_tool(cli_bar):
    om, report = cli_bar
    V, E, handles, targets, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    w = diffreg.diffuse_weights(V, E, handles, ranges, magnitudes, t=0.01)
    X, info = diffreg.deform(V, E, handles, targets, weights=w, energy="arap",
                             regularization="nonuniform")
    Vc, Ec, vprops, eprops = diffreg.read_mesh(om, properties=True)
    assert np.array_equal(Ec, E)
    np.testing.assert_allclose(w, vprops["diffreg:weight"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(X, Vc, rtol=0, atol=1e-9)
    deform = report["filters"][1]
    assert info["iterations"] == deform["iterations"]
    assert info["converged"] == deform["converged"] is True
    np.testing.assert_allclose(info["energies"], deform["energies"], rtol=1e-10)
    for key in ("criterion", "symbolic", "numeric", "solves"):
        assert key in info
    # The Table-1 metrics: Dist against the same edit without regularization.
    X0, _ = diffreg.deform(V, E, handles, targets, energy="arap", regularization="none")
    metrics = diffreg.measure(V, E, X, weights=w, energy="arap", regularization="nonuniform",
                              reference=X0)
    for key, value in report["filters"][2]["metrics"].items():
        assert metrics[key] == pytest.approx(value, rel=1e-8, abs=1e-12), key
    np.testing.assert_allclose(metrics["distortion"], eprops["diffreg:distortion"], atol=1e-12)


def test_run_equals_the_tool(cli_bar):
    om, report = cli_bar
    result = diffreg.run(mesh("bar.obj"), ["diffuse_weights t=0.01",
                                           "deform energy=arap regularization=nonuniform",
                                           "measure"], handles=mesh("bar-bend.json"))
    Vc, _ = diffreg.read_mesh(om)
    np.testing.assert_allclose(result["V"], Vc, rtol=0, atol=1e-9)
    assert set(result["vertex_properties"]) >= {"diffreg:weight"}
    assert set(result["element_properties"]) >= {"diffreg:distortion", "diffreg:smoothness"}
    got = result["report"]["filters"]
    assert [f["name"] for f in got] == ["diffuse_weights", "deform", "measure"]
    assert got[1]["iterations"] == report["filters"][1]["iterations"]
    for key, value in report["filters"][2]["metrics"].items():
        assert got[2]["metrics"][key] == pytest.approx(value, rel=1e-8, abs=1e-12)


def test_run_on_arrays_with_handle_lists():
    V, E, handles, targets, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    result = diffreg.run((V, E), ["diffuse_weights", "deform regularization=nonuniform"],
                         handles=handles, targets=targets, ranges=ranges, magnitudes=magnitudes)
    w = diffreg.diffuse_weights(V, E, handles, ranges, magnitudes)
    X, _ = diffreg.deform(V, E, handles, targets, weights=w, regularization="nonuniform")
    np.testing.assert_array_equal(result["vertex_properties"]["diffreg:weight"], w)
    np.testing.assert_allclose(result["V"], X, atol=1e-12)


def test_run_writes_the_filters_files_only_when_every_step_succeeds(tmp_path):
    V, E, handles, targets, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    picture, kept = tmp_path / "w.png", tmp_path / "kept.png"
    kept.write_bytes(b"old")
    steps = ["diffuse_weights", f"render file={picture}", f"render file={kept}",
             "deform regularization=nonuniform"]
    # The third render fails, after the first two have drawn.
    with pytest.raises(ValueError, match="is written twice"):
        diffreg.run((V, E), steps + [f"render file={picture}"], handles=handles,
                    targets=targets, ranges=ranges, magnitudes=magnitudes)
    assert not picture.exists()
    assert kept.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.png"]
    # A warning the filters make an error fails the run too, before its files appear.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(diffreg.DiffregWarning, match="beta=0.3 is ignored"):
            diffreg.run((V, E), steps[:3] + ["deform beta=0.3"], handles=handles,
                        targets=targets, ranges=ranges, magnitudes=magnitudes)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.png"]
    diffreg.run((V, E), steps, handles=handles, targets=targets, ranges=ranges,
                magnitudes=magnitudes)
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert kept.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_run_names_a_handle_file_that_holds_no_handles(tmp_path):
    empty = tmp_path / "empty.json"
    empty.write_text('{"handles": []}')
    V, E, *_ = scenario("bar.obj", "bar-bend.json")
    for source in (mesh("bar.obj"), (V, E)):
        with pytest.raises(ValueError, match="the handle file '.*empty.json' holds none"):
            diffreg.run(source, ["deform"], handles=str(empty))


def test_run_with_a_meshlab_script(tmp_path):
    script = tmp_path / "weights.mlx"
    script.write_text('<!DOCTYPE FilterScript>\n<FilterScript>\n'
                      ' <filter name="diffuse_weights"/>\n</FilterScript>\n')
    both = diffreg.run(mesh("bar.obj"), ["deform regularization=nonuniform"],
                       handles=mesh("bar-bend.json"), script=str(script))
    plain = diffreg.run(mesh("bar.obj"), ["diffuse_weights", "deform regularization=nonuniform"],
                        handles=mesh("bar-bend.json"))
    np.testing.assert_allclose(both["V"], plain["V"], rtol=0, atol=1e-12)
    with pytest.raises(OSError):
        diffreg.run(mesh("bar.obj"), script=str(tmp_path / "missing.mlx"))


# ---- the C++ API on the shipped meshes ----------------------------------------------------------

@pytest.mark.parametrize("mesh_name,handles_name", SCENARIOS)
def test_shipped_scenarios(mesh_name, handles_name):
    V, E, handles, targets, ranges, magnitudes = scenario(mesh_name, handles_name)
    assert V.dtype == np.float64 and V.shape[1] == 3
    assert E.shape[1] == (4 if mesh_name.endswith(".mesh") else 3)
    w = diffreg.diffuse_weights(V, E, handles, ranges, magnitudes)
    assert w.shape == (len(V),)
    assert w.min() >= 0 and w.max() <= magnitudes.max() + 1e-12
    for h, m in zip(handles, magnitudes):
        np.testing.assert_allclose(w[h], m)
    X, info = diffreg.deform(V, E, handles, targets, weights=w, regularization="nonuniform")
    assert X.shape == V.shape and np.isfinite(X).all()
    assert info["converged"]
    assert all(b <= a * (1 + 1e-12) for a, b in zip(info["energies"], info["energies"][1:]))
    for h, t in zip(handles, targets):
        np.testing.assert_allclose(X[h], t, atol=1e-9)
    if np.ptp(V[:, 2]) == 0:  # planar: z kept
        np.testing.assert_array_equal(X[:, 2], V[:, 2])
    metrics = diffreg.measure(V, E, X, weights=w, regularization="nonuniform")
    assert metrics["inverted"] == 0 and metrics["dist"] is None
    assert metrics["D_max"] >= metrics["D_ave"] >= 0
    rbf = diffreg.rbf_weights(V, E, handles, ranges, magnitudes, distance="euclidean")
    assert rbf.shape == (len(V),) and rbf.min() >= 0


def test_defaults_come_from_the_filter_tables():
    tables = {f["name"]: {p["name"]: p for p in f["params"]} for f in diffreg.filters()}
    deform = tables["deform"]
    doc = diffreg.deform.__doc__
    assert doc.startswith("deform(V, E, handles, targets, weights=None")
    for name, p in deform.items():
        assert name in doc and p["help"][:40] in doc
    assert "iterations=" + deform["iterations"]["default"] in doc
    assert "t=" + tables["diffuse_weights"]["t"]["default"] in diffreg.diffuse_weights.__doc__
    V, E, handles, targets, _, _ = scenario("bar.obj", "bar-bend.json")
    X, info = diffreg.deform(V, E, handles, targets)
    assert info["params"] == {name: p["default"] for name, p in deform.items()}


def test_array_forms():
    V, E, handles, targets, _, _ = scenario("bar.obj", "bar-bend.json")
    X, _ = diffreg.deform(V, E, handles, targets)
    stacked = np.vstack(targets)
    X2, _ = diffreg.deform(np.asfortranarray(V), E.astype(np.int32), [list(h) for h in handles],
                           stacked)
    np.testing.assert_array_equal(X, X2)
    X3, _ = diffreg.deform(V[:, :2].copy(), E, handles, [t[:, :2] for t in targets])
    np.testing.assert_allclose(X3, X, atol=1e-12)


def test_write_and_read_properties(tmp_path):
    V, E = square()
    w = np.array([0.0, 0.25, 0.5, 1.0])
    d = np.array([1.0, 2.0])
    path = str(tmp_path / "square.om")
    diffreg.write_mesh(path, V, E, vertex_properties={"diffreg:weight": w},
                       element_properties={"diffreg:distortion": d})
    V2, E2, vp, ep = diffreg.read_mesh(path, properties=True)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(E2, E)
    np.testing.assert_array_equal(vp["diffreg:weight"], w)
    np.testing.assert_array_equal(ep["diffreg:distortion"], d)
    ply = str(tmp_path / "square.ply")
    diffreg.write_mesh(ply, V, E, vertex_properties={"diffreg:weight": w})
    assert "property double quality" in open(ply).read()


def test_threads_solve_at_once():
    """The GIL is released during solves: threads run side by side and agree."""
    from concurrent.futures import ThreadPoolExecutor
    V, E, handles, targets, _, _ = scenario("cylinder.obj", "cylinder-twist.json")
    with ThreadPoolExecutor(max_workers=3) as pool:
        results = list(pool.map(lambda _: diffreg.deform(V, E, handles, targets)[0], range(3)))
    for X in results[1:]:
        np.testing.assert_allclose(X, results[0], rtol=0, atol=1e-10)


def test_one_session_shared_by_threads():
    """A session's methods run one at a time, whichever threads call them: every solve uses the
    targets one of the threads set, whole, and solves as a session of its own would."""
    from concurrent.futures import ThreadPoolExecutor
    V, E, handles, targets, _, _ = scenario("cylinder.obj", "cylinder-twist.json")

    def moved(k):
        return [t + [0.0, 0.0, 0.05 * k] for t in targets]

    def session():
        s = diffreg.DeformationSession(V, E, iterations=60, tolerance=0)
        s.set_handles(handles)
        return s
    expected = []
    for k in range(2):
        alone = session()
        alone.set_targets(moved(k))
        expected.append(alone.solve()[0])
    shared = session()

    def work(k):
        out = []
        for _ in range(10):
            shared.set_targets(moved(k))
            out.append(shared.solve()[0])
            shared.stats
            shared.last_targets()
        return out
    with ThreadPoolExecutor(max_workers=2) as pool:
        runs = list(pool.map(work, range(2)))
    for X in runs[0] + runs[1]:
        assert min(np.abs(X - e).max() for e in expected) < 1e-9

    # A call from within one of the session's own calls is an error, not a wait on itself.
    class Handles(list):
        def __getitem__(self, j):
            shared.stats  # the session is in set_handles
            return list.__getitem__(self, j)
    with pytest.raises(RuntimeError, match="within one of its own calls"):
        shared.set_handles(Handles(handles))
    shared.set_handles(handles)
    shared.set_targets(moved(1))  # the session is free again
    np.testing.assert_allclose(shared.solve()[0], expected[1], rtol=0, atol=1e-9)


# ---- errors ---------------------------------------------------------------------------------------

def test_warnings_go_through_the_warnings_module(tmp_path, capfd):
    path = tmp_path / "extra.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nfoo bar\nf 1 2 3\n")
    with pytest.warns(diffreg.DiffregWarning, match="no OBJ statement") as record:
        diffreg.read_mesh(str(path))
    assert issubclass(diffreg.DiffregWarning, UserWarning)
    assert record[0].filename == __file__  # issued at the caller's line
    # An unconverged deform() says so; so does a session's constructor about an unused vertex.
    V, E, handles, targets, _, _ = scenario("bar.obj", "bar-bend.json")
    with pytest.warns(diffreg.DiffregWarning, match="not converged"):
        diffreg.deform(V, E, handles, targets, iterations=2)
    spare = np.vstack([V, [[100.0, 100.0, 0.0]]])
    with pytest.warns(diffreg.DiffregWarning, match="unreferenced"):
        diffreg.DeformationSession(spare, E)
    # A parameter given that the others leave without effect is named, in deform() and sessions.
    with pytest.warns(diffreg.DiffregWarning, match="beta=0.3 is ignored"):
        diffreg.deform(V, E, handles, targets, beta=0.3)
    with pytest.warns(diffreg.DiffregWarning, match="acceleration=anderson is ignored"):
        diffreg.DeformationSession(V, E, local_step="reference", acceleration="anderson")
    session = diffreg.DeformationSession(V, E, energy="dirichlet")
    session.set_handles(handles)
    session.set_targets(targets)
    with pytest.warns(diffreg.DiffregWarning, match="iterations=7 is ignored: energy=dirichlet"):
        session.solve(iterations=7)
    with pytest.warns(diffreg.DiffregWarning, match="beta=0.3 is ignored"):
        session.set_regularization("none", beta=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        session.set_regularization("uniform", beta=0.3)
        session.solve()
    # Nothing of it reaches stderr, and the warnings filters apply: "error" raises.
    assert "warning" not in capfd.readouterr().err
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(diffreg.DiffregWarning, match="no OBJ statement"):
            diffreg.read_mesh(str(path))
        for session in (diffreg.DeformationSession, diffreg.DiffusionWeights):
            with pytest.raises(diffreg.DiffregWarning, match="unreferenced"):
                session(spare, E)
        # write_mesh says its warnings before the file is put in place: as an error, the file
        # keeps what it held.
        keep = tmp_path / "keep.ply"
        keep.write_text("precious")
        with pytest.raises(diffreg.DiffregWarning, match="'a b' is not written"):
            diffreg.write_mesh(str(keep), V, E, vertex_properties={"a b": np.ones(len(V))})
        assert keep.read_text() == "precious"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["extra.obj", "keep.ply"]
        warnings.simplefilter("ignore")
        V2, _ = diffreg.read_mesh(str(path))
    assert V2.shape == (3, 3)
    with pytest.warns(diffreg.DiffregWarning, match=r"'a b' is not written"):
        diffreg.write_mesh(str(keep), V, E, vertex_properties={"a b": np.ones(len(V))})
    assert keep.read_text().startswith("ply")


def test_errors_are_python_exceptions_with_the_tools_messages(tmp_path):
    V, E = square()
    with pytest.raises(OSError, match="nothing.obj"):
        diffreg.read_mesh(str(tmp_path / "nothing.obj"))
    with pytest.raises(ValueError, match=r"V: expected positions of shape \(n, 3\)"):
        diffreg.diffuse_weights(np.zeros((4, 4)), E, [[0]])
    with pytest.raises(ValueError, match="V: expected real numbers"):
        diffreg.diffuse_weights(np.array([["a"] * 3] * 4), E, [[0]])
    with pytest.raises(ValueError, match="E: expected integer indices"):
        diffreg.diffuse_weights(V, E.astype(float), [[0]])
    with pytest.raises(ValueError, match="refers to vertex 7"):
        diffreg.diffuse_weights(V, np.array([[0, 1, 7]]), [[0]])
    with pytest.raises(ValueError, match="non-finite"):
        diffreg.diffuse_weights(np.where(V == 1, np.nan, V), E, [[0]])
    with pytest.raises(ValueError, match="one handle write"):
        diffreg.diffuse_weights(V, E, [0, 1])
    with pytest.raises(ValueError, match="out of range"):
        diffreg.diffuse_weights(V, E, [[9]])
    # An unsigned id past the int64 range is named as given, not as the wrapped negative.
    big = np.uint64(2**63)
    with pytest.raises(ValueError, match="vertex 9223372036854775808 out of range"):
        diffreg.diffuse_weights(V, E, [np.array([big])])
    with pytest.raises(ValueError, match="refers to vertex 9223372036854775808,"):
        diffreg.diffuse_weights(V, E.astype(np.uint64) + big, [[0]])
    with pytest.raises(ValueError, match="'tt'.*t"):
        diffreg.diffuse_weights(V, E, [[0]], tt=1)
    with pytest.raises(ValueError, match="order"):
        diffreg.diffuse_weights(V, E, [[0]], order="third")
    with pytest.raises(ValueError, match="beta"):
        diffreg.deform(V, E, [[0], [2]], None, regularization="uniform", beta=2)
    with pytest.raises(ValueError, match="nonuniform needs weights"):
        diffreg.deform(V, E, [[0], [2]], None, regularization="nonuniform")
    with pytest.raises(ValueError, match=r"targets: expected shape \(2, 3\)"):
        diffreg.deform(V, E, [[0], [2]], np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"weights: expected shape \(4,\)"):
        diffreg.deform(V, E, [[0], [2]], None, regularization="nonuniform", weights=[1, 2])
    with pytest.raises(ValueError, match="degenerate"):
        diffreg.deform(np.zeros((4, 3)), E, [[0], [2]], None)
    # The first face that does not fit is named, with its reason: face 2 runs along the edge 0-2
    # in the direction face 1 does, before face 3 repeats a vertex.
    with pytest.raises(ValueError, match="face 2 \\(0-based\\) makes the mesh non-manifold"):
        diffreg.diffuse_weights(V, np.array([[0, 1, 2], [0, 2, 3], [0, 2, 1], [3, 3, 1]]), [[0]])
    with pytest.raises(ValueError, match="face 1 \\(0-based\\) repeats a vertex"):
        diffreg.diffuse_weights(V, np.array([[0, 1, 2], [3, 3, 1], [0, 2, 1]]), [[0]])
    with pytest.raises(ValueError, match="unknown filter|no_such_filter"):
        diffreg.run((V, E), ["no_such_filter"])
    with pytest.raises(ValueError, match="handle"):
        diffreg.run((V, E), ["deform"])
    with pytest.raises(ValueError):
        diffreg.deform(V, E, [[0], [0]], None)
    # Weights without the regularization that uses them, 2-coordinate targets on a surface and
    # an empty handle list are refused, not ignored or completed.
    with pytest.raises(ValueError, match="weights are used by regularization='nonuniform' only"):
        diffreg.deform(V, E, [[0], [2]], None, weights=np.ones(4))
    with pytest.raises(ValueError, match="weights are used by regularization='nonuniform' only"):
        diffreg.DeformationSession(V, E, weights=np.ones(4))
    with pytest.raises(ValueError, match="the list is empty"):
        diffreg.diffuse_weights(V, E, [])
    with pytest.raises(ValueError, match="the list is empty"):
        diffreg.deform(V, E, [], [])
    Vs, Es = diffreg.read_mesh(mesh("cylinder.obj"))
    with pytest.raises(ValueError, match=r"targets\[0\]: expected shape \(1, 3\)"):
        diffreg.deform(Vs, Es, [[0], [5]], [Vs[[0], :2], Vs[[5], :2]])



def test_parameters_keep_their_value_and_every_byte():
    V, E = square()
    # A 0-d numpy array is its number: int() would truncate 0.5 to 0, and 1.7 to an in-range 1.
    _, info = diffreg.deform(V, E, [[0], [2]], None, regularization="uniform", beta=np.array(0.5))
    assert info["params"]["beta"] == "0.5"
    with pytest.raises(ValueError, match="'beta' = '1.7' is out of range"):
        diffreg.deform(V, E, [[0], [2]], None, regularization="uniform", beta=np.array(1.7))
    _, info = diffreg.deform(V, E, [[0], [2]], None, iterations=np.array(7), tolerance=np.float32(0.5))
    assert info["params"]["iterations"] == "7" and info["params"]["tolerance"] == "0.5"
    # numpy's bool is a bool, as True is: not the integer 1.
    with pytest.raises(ValueError, match="'iterations' = 'true' is not an integer"):
        diffreg.deform(V, E, [[0], [2]], None, iterations=np.bool_(True))
    # A NUL byte is refused, never the end of the value.
    with pytest.raises(ValueError, match=r"'beta' = '0.9\\x00garbage' has a NUL byte"):
        diffreg.deform(V, E, [[0], [2]], None, regularization="uniform", beta="0.9\x00garbage")
    with pytest.raises(ValueError, match="the specification has a NUL byte"):
        diffreg.run((V, E), ["deform regularization=uniform beta=0.9\x00garbage"], handles=[[0], [2]])


def test_run_refuses_handle_values_it_would_not_use(tmp_path):
    V, E, handles, targets, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    with pytest.raises(ValueError, match="run: targets go with a list of handles, not with a handle file"):
        diffreg.run(mesh("bar.obj"), ["deform"], handles=mesh("bar-bend.json"), targets=targets)
    with pytest.raises(ValueError, match="run: ranges go with a list of handles, and none is given"):
        diffreg.run((V, E), ["measure"], ranges="x")
    with pytest.raises(ValueError, match="run: magnitudes go with a list of handles"):
        diffreg.run((V, E), ["measure"], handles=mesh("bar-bend.json"), magnitudes=magnitudes)


def test_scalar_arguments_of_a_wrong_type_are_named_in_one_line(tmp_path):
    V, E, handles, _, _, _ = scenario("bar.obj", "bar-bend.json")
    cases = [
        (lambda: diffreg.write_mesh(str(tmp_path / "x.ply"), V, E, colors="no"),
         "colors: expected a bool, got str"),
        (lambda: diffreg.write_mesh(str(tmp_path / "x.ply"), V, E, vertex_quality=None),
         "vertex_quality: expected a str, got NoneType"),
    ]
    session = diffreg.DeformationSession(V, E)
    cases += [
        (lambda: session.set_beta("x"), "beta: expected a number, got str"),
        (lambda: session.set_regularization("uniform", beta=[0.5]), "beta: expected a number, got list"),
        (lambda: session.set_time_budget(True), "seconds: expected a number, got bool"),
        (lambda: session.set_beta(1e308), r"beta = 1e308 is outside \[0, 1\]$"),
    ]
    weights = diffreg.DiffusionWeights(V, E)
    weights.set_handles(handles)
    cases += [
        (lambda: weights.set_range(0, "x"), "r: expected a number, got str"),
        (lambda: weights.set_range(2**70, 1.0), "handle: 1180591620717411303424 is out of range"),
        (lambda: weights.set_magnitude(True, 0.5), "handle: expected an integer, got bool"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message) as caught:
            call()
        assert "\n" not in str(caught.value) and len(str(caught.value)) < 200
    # An object's own exception from __array__ reaches the caller as itself.
    class Refuses:
        def __array__(self, *args, **kwargs):
            raise RuntimeError("mine")
    with pytest.raises(RuntimeError, match="mine"):
        diffreg.diffuse_weights(Refuses(), E, handles)
    with pytest.raises(ValueError, match=r"targets: 2 arrays for 3 handles"):
        diffreg.deform(V, E, [[0], [5], [9]], [V[[0]], V[[5]]])
    # The object's own exception from __index__ or __float__ reaches the caller as itself.
    class IndexRaises:
        def __index__(self):
            raise KeyboardInterrupt
    class FloatRaises:
        def __float__(self):
            raise RuntimeError("boom-float")
    with pytest.raises(KeyboardInterrupt):
        weights.set_range(IndexRaises(), 1.0)
    with pytest.raises(RuntimeError, match="boom-float"):
        session.set_beta(FloatRaises())
    with pytest.raises(ValueError, match="'iterations' = 'true' is not an integer"):
        diffreg.deform(V, E, handles, None, iterations=np.array(True))
    # write_mesh names the path given: no extension, a directory.
    with pytest.raises(OSError, match=r"\(no extension\)"):
        diffreg.write_mesh(str(tmp_path / "noext"), V, E)
    with pytest.raises(OSError, match="it is a directory"):
        (tmp_path / "d.ply").mkdir()
        diffreg.write_mesh(str(tmp_path / "d.ply"), V, E)
    # A far vertex that no element uses is measured by nothing.
    far = np.vstack([V, [[1e31, 0.0, 0.0]]])
    with pytest.warns(diffreg.DiffregWarning, match="unreferenced"):
        assert np.isfinite(diffreg.measure(far, E, far)["D_max"])
    # numpy's scalars are numbers.
    weights.set_range(np.int64(1), np.float64(2.0))
    session.set_beta(np.array(0.25))
    assert [p.name for p in tmp_path.iterdir()] == ["d.ply"]


def test_an_object_made_without_init_is_refused_not_used():
    for cls in (diffreg.DeformationSession, diffreg.DiffusionWeights):
        unbuilt = cls.__new__(cls)
        with pytest.raises(TypeError, match="made without __init__"):
            unbuilt.solve()
        with pytest.raises(TypeError, match="made without __init__"):
            unbuilt.stats
        with pytest.raises(TypeError, match="method called on a int"):
            cls.solve(42)


# ---- sessions (paper Fig. 5) ----------------------------------------------------------------------

def test_diffusion_session_reuses_its_factorization():
    V, E, handles, _, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    session = diffreg.DiffusionWeights(V, E, t=0.01)
    session.set_handles(handles, ranges, magnitudes)
    w = session.solve()
    np.testing.assert_allclose(w, diffreg.diffuse_weights(V, E, handles, ranges, magnitudes),
                               atol=1e-12)
    s0 = session.stats
    # The second order by PCG: each solve is a few back-substitutions with the one factor.
    assert (s0["symbolic"], s0["numeric"]) == (1, 1) and s0["solves"] >= 2
    session.set_magnitude(2, 1.0)  # right-hand side only: CG again, no factorization
    session.solve()
    s1 = session.stats
    assert (s1["symbolic"], s1["numeric"]) == (1, 1) and s1["solves"] > s0["solves"]
    session.set_params(t=0.02)  # numeric factorization only
    w2 = session.solve()
    s2 = session.stats
    assert (s2["symbolic"], s2["numeric"]) == (1, 2)
    assert session.params["t"] == "0.02" and session.params["order"] == "second"
    session.set_range(0, 2.0)
    session.solve()
    assert (session.stats["symbolic"], session.stats["numeric"]) == (1, 3)
    assert w2.mean() > w.mean()
    with pytest.raises(ValueError):
        session.set_magnitude(5, 1.0)
    direct = diffreg.DiffusionWeights(V, E, t=0.01, solve="direct")  # one solve per right-hand side
    direct.set_handles(handles, ranges, magnitudes)
    np.testing.assert_allclose(direct.solve(), w, atol=1e-9)
    direct.set_magnitude(2, 1.0)
    direct.solve()
    assert (direct.stats["symbolic"], direct.stats["numeric"], direct.stats["solves"]) == (1, 1, 2)


def test_deformation_session_reuses_its_factorization():
    V, E, handles, targets, ranges, magnitudes = scenario("bar.obj", "bar-bend.json")
    w = diffreg.diffuse_weights(V, E, handles, ranges, magnitudes)
    session = diffreg.DeformationSession(V, E, weights=w, regularization="nonuniform")
    session.set_handles(handles)
    session.set_targets(targets)
    X, info = session.solve()
    X1, _ = diffreg.deform(V, E, handles, targets, weights=w, regularization="nonuniform")
    np.testing.assert_allclose(X, X1, atol=1e-12)
    assert info["converged"] and info["iterations"] > 0
    s0 = session.stats
    assert s0["symbolic"] >= 1 and s0["numeric"] >= 1
    moved = [t + np.array([0, 0.1, 0]) for t in targets]
    session.set_targets(moved)  # solves only
    session.solve()
    s1 = session.stats
    assert (s1["symbolic"], s1["numeric"]) == (s0["symbolic"], s0["numeric"])
    assert s1["solves"] > s0["solves"]
    session.set_beta(0.3)  # numeric factorization only
    session.solve(iterations=5)
    s2 = session.stats
    assert s2["symbolic"] == s0["symbolic"] and s2["numeric"] > s1["numeric"]
    Xr, info = session.resume()
    assert info["initial_guess"] == "continued" and info["converged"]
    # The run's last targets start the energy metric at its shape: the same value.
    T = session.last_targets()
    assert T is not None and T.shape[1] in (2, 3) and T.shape[0] == T.shape[1] * len(E)
    fit = diffreg.measure(V, E, Xr, regularization="uniform", beta=0.3)  # set_beta(0.3) above
    run = diffreg.measure(V, E, Xr, regularization="uniform", beta=0.3, start_targets=T)
    assert run["energy"] == pytest.approx(fit["energy"], rel=1e-9)
    with pytest.raises(ValueError):
        diffreg.measure(V, E, Xr, start_targets=T[:-T.shape[1]])
    # A time budget spent at once: one iteration per call, the same end as one run.
    session.set_beta(0.4)
    once, info_once = session.solve()
    session.set_time_budget(1e-9)
    X, info = session.solve()
    calls = 1
    while not info["converged"] and calls < 10000:
        X, info = session.resume()
        calls += 1
    assert info["converged"] and calls > 1
    np.testing.assert_array_equal(X, once)
    session.set_time_budget(0)
    with pytest.raises(ValueError):
        session.set_time_budget(-1)
    session.set_regularization("none")
    assert session.last_targets() is None  # nothing to continue
    Xf, info = session.solve_from(Xr, iterations=100)
    assert info["initial_guess"] == "given"
    assert session.stats["symbolic"] == s0["symbolic"]


# ---- file paths ----------------------------------------------------------------------------------

def test_paths_may_be_pathlib_or_bytes_and_a_nul_is_refused(tmp_path):
    import pathlib
    meshes = pathlib.Path(MESHES)
    V, E = diffreg.read_mesh(meshes / "bar.obj")
    Vb, Eb = diffreg.read_mesh(os.fsencode(mesh("bar.obj")))
    np.testing.assert_array_equal(V, Vb)
    handles, targets, _, _, _ = diffreg.read_handles(meshes / "bar-bend.json", V, E)
    diffreg.write_mesh(tmp_path / "bar.ply", V, E)
    np.testing.assert_array_equal(diffreg.read_mesh(tmp_path / "bar.ply")[0], V)
    out = diffreg.run(meshes / "bar.obj", ["diffuse_weights"], handles=meshes / "bar-bend.json")
    assert out["report"]["filters"][0]["name"] == "diffuse_weights"
    out = diffreg.run((V, E), ["diffuse_weights"], handles=meshes / "bar-bend.json")
    assert "diffreg:weight" in out["vertex_properties"]
    with pytest.raises(ValueError, match="file path"):
        diffreg.read_mesh(3)
    # The system would read or write the name cut at the NUL: "cut" here.
    (tmp_path / "cut").write_text("kept")
    cut = str(tmp_path / "cut")
    for call in (lambda: diffreg.read_mesh(cut + "\0.obj"),
                 lambda: diffreg.read_mesh(cut + "\0.foo"),
                 lambda: diffreg.read_mesh(cut + "\0.node"),
                 lambda: diffreg.write_mesh(cut + "\0.ply", V, E),
                 lambda: diffreg.write_mesh(cut + "\0.foo", V, E),
                 lambda: diffreg.read_handles(cut + "\0.json", V, E)):
        with pytest.raises(OSError, match=r"cut\\x00\..*NUL byte"):
            call()
    assert (tmp_path / "cut").read_text() == "kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bar.ply", "cut"]
    # A name that is not UTF-8, as os.listdir gives it (surrogate escapes), as open() takes it.
    odd = os.fsdecode(b"caf\xe9.ply")
    diffreg.write_mesh(tmp_path / odd, V, E)
    assert os.path.exists(os.path.join(os.fsencode(tmp_path), b"caf\xe9.ply"))
    np.testing.assert_array_equal(diffreg.read_mesh(tmp_path / odd)[0], V)
    np.testing.assert_array_equal(diffreg.read_mesh(str(tmp_path / odd))[0], V)


# ---- progress and interruption --------------------------------------------------------------------

class Stop(Exception):
    pass


def test_progress_sees_every_iteration_and_its_exception_ends_the_run():
    V, E, handles, targets, _, _ = scenario("cylinder.obj", "cylinder-twist.json")
    seen = []
    X, info = diffreg.deform(V, E, handles, targets,
                             progress=lambda i, energy, criterion: seen.append((i, energy)))
    assert info["converged"] and len(seen) == info["iterations"] > 3
    assert [i for i, _ in seen] == list(range(1, info["iterations"] + 1))
    assert [e for _, e in seen] == info["energies"][-len(seen):]
    ran = []
    out = diffreg.run((V, E), ["deform"], handles=handles, targets=targets,
                      progress=lambda i, energy, criterion: ran.append((i, energy)))
    assert ran == seen
    np.testing.assert_array_equal(out["V"], X)

    def stop(i, energy, criterion):
        if i == 3:
            raise Stop("enough")
    with pytest.raises(Stop, match="enough"):
        diffreg.deform(V, E, handles, targets, progress=stop)
    with pytest.raises(Stop):
        diffreg.run((V, E), ["deform"], handles=handles, targets=targets, progress=stop)
    # A session stopped by its callback keeps working: nothing to continue, the next solve
    # (without a callback: the hook went with the call) runs afresh to the same shape.
    def session():
        s = diffreg.DeformationSession(V, E)
        s.set_handles(handles)
        s.set_targets(targets)
        return s
    uninterrupted, _ = session().solve()
    stopped = session()
    with pytest.raises(Stop):
        stopped.solve(progress=stop)
    again, info = stopped.resume()
    assert info["initial_guess"] != "continued" and info["converged"]
    np.testing.assert_array_equal(again, uninterrupted)
    session = stopped
    with pytest.raises(Stop):
        session.solve_from(X, progress=lambda *args: stop(3, 0, 0))
    with pytest.raises(ValueError, match="progress"):
        diffreg.deform(V, E, handles, targets, progress=3)


def test_ctrl_c_stops_a_running_deformation():
    # Plain local/global to rounding level runs for seconds here; Ctrl-C (as interrupt_main
    # delivers it) stops it at once, as a KeyboardInterrupt, with nothing left to continue.
    V, E, handles, targets, _, _ = scenario("cylinder.obj", "cylinder-twist.json")
    session = diffreg.DeformationSession(V, E, acceleration="none", regularization="uniform")
    session.set_handles(handles)
    session.set_targets(targets)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    with pytest.raises(KeyboardInterrupt):
        timer.start()
        session.solve(iterations=100000, tolerance=0)
        time.sleep(60)  # an interrupt that came only after the solve lands here
    timer.join()
    X, info = session.resume(iterations=1)
    assert info["initial_guess"] != "continued"


# ---- the example ----------------------------------------------------------------------------------

def test_example_script(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "three-ways.png"
    script = os.path.join(SOURCE, "examples", "python", "deform_three_ways.py")
    subprocess.run([sys.executable, script, "-o", str(out)], check=True,
                   env=dict(os.environ, MPLBACKEND="Agg"))
    assert out.stat().st_size > 10000


# ---- installation ---------------------------------------------------------------------------------

def test_installed_module_imports(tmp_path):
    cmake, build = os.environ.get("DIFFREG_CMAKE"), os.environ.get("DIFFREG_BUILD_DIR")
    relative = os.environ.get("DIFFREG_PYTHON_INSTALL_DIR")
    if not (cmake and build and relative):
        pytest.skip("run by ctest, which names the build")
    prefix = tmp_path / "prefix"
    subprocess.run([cmake, "--install", build, "--prefix", str(prefix)], check=True,
                   stdout=subprocess.DEVNULL)
    site = relative if os.path.isabs(relative) else str(prefix / relative)
    env = dict(os.environ, PYTHONPATH=site)
    out = subprocess.run([sys.executable, "-c", "import diffreg; print(diffreg.__file__)"],
                         check=True, env=env, cwd=str(tmp_path), capture_output=True, text=True)
    assert out.stdout.strip().startswith(site)
