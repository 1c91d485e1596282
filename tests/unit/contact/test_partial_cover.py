"""Slave facets only partly over the master: momentum across the interface (issue #23, F1).

A slave surface wider than its master, a master wider than its slave and surfaces offset
so that each one's edge crosses the other's facets at several positions, in 2D and 3D.
The dual basis of a partly covered slave facet is built on its covered part
(docs/theory/mortar.md#partly-covered-facets), so on every slave row

* ``sum_q M_pq = D_pp`` (the slave and the master receive equal and opposite forces);
* ``D_pp = int_cov phi_p``, and ``sum_p D_pp`` is the overlap's measure (exact here);
* flat, parallel surfaces: ``sum_q M_pq x_q = D_pp x_p`` (``M^ = D^-1 M`` reproduces
  linear functions) and the weighted gap is ``g D_pp``.

Then the assembled ``M^`` rows of :func:`build_interface` sum to 1 on 1, 2 and 3 ranks,
and full runs (``bonecontact run``: traction on the slave's top, the slave held vertically
only by the contact) show reactions that balance the loads to 1e-8 (history.csv and
summary.json), with the contact's normal force equal to the load.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import csv
import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from mortar_meshes import flat_surface, line, lumped, row_sums

from bonecontact.contact.geometry import nodal_normals
from bonecontact.contact.interface import build_interface
from bonecontact.contact.mortar_assembly import assemble_mortar
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes
from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import load_scene

COMM = MPI.COMM_WORLD
GAP = 0.013

#: master extent [lo, hi] (per direction) under the slave [0, 1]: slave wider (edges
#: inside slave facets), master wider, and offsets of 0.1, 0.5, 0.9 and 1.3 slave facets
#: (the slave has 5 facets per direction) so that the slave's edge crosses the master's
#: facets, and the master's edge the slave's, at several positions.
LAYOUTS = {
    "wide_slave": (0.11, 0.93),
    "wide_master": (-0.1, 1.1),
    "offset0.1": (0.02, 1.02),
    "offset0.5": (0.1, 1.1),
    "offset0.9": (-0.18, 0.82),
    "offset1.3": (0.26, 1.26),
}


def _surfaces(dim: int, layout: str, seed: int):
    """Slave [0, 1]^(dim-1) (5 facets a side) at height 0, master over LAYOUTS[layout]
    (13 or 7 facets a side, non-matching, perturbed) at height GAP, facing it."""
    rng = np.random.default_rng(seed)
    lo, hi = LAYOUTS[layout]
    if dim == 2:
        xs, fs = line(5, 0.0, 1.0, 0.0, rng, perturb=0.3)
        xm, fm = line(13, lo, hi, GAP, rng, perturb=0.3)
        ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 1.0])
        return xs, fs, ns, xm, fm[:, ::-1]
    xs, fs = flat_surface(5, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = flat_surface(7, lo, hi, GAP, rng, perturb=0.3, flip=True)
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    return xs, fs, ns, xm, fm


def _overlap(dim: int, layout: str) -> float:
    """Measure of the overlap of the slave [0, 1]^(dim-1) and the master (exact)."""
    lo, hi = LAYOUTS[layout]
    return (min(hi, 1.0) - max(lo, 0.0)) ** (dim - 1)


# ----------------------------------------------------------------------------- D and M
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_partly_covered_rows_balance(dim, layout):
    xs, fs, ns, xm, fm = _surfaces(dim, layout, seed=31 + dim)
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    partial = ~res.fully_covered_facets(rtol=1e-12) & (res.covered_area > 0.0)
    full = res.fully_covered_nodes(fs, rtol=1e-12)
    if layout != "wide_master":
        assert partial.sum() > 0 and 0 < full.sum() < len(xs)
    # the forces on the slave (D) and on the master (M^T) are equal on every row
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, rtol=0, atol=1e-14)
    assert len(res.d_off_vals) == 0
    # D_pp = int_cov phi_p >= 0: its sum is the overlap, fully covered nodes the lumped mass
    assert np.all(res.d >= -1e-15)
    assert res.d.sum() == pytest.approx(_overlap(dim, layout), rel=1e-12)
    np.testing.assert_allclose(res.d[full], lumped(xs, fs)[full], rtol=1e-12)
    # M^ = D^-1 M interpolates the master's coordinates at the slave nodes (flat, parallel)
    carry = res.d > 1e-3 * lumped(xs, fs)
    for c in range(dim - 1):
        mx = np.bincount(res.m_rows, weights=res.m_vals * xm[res.m_cols, c], minlength=len(xs))
        np.testing.assert_allclose(mx[carry] / res.d[carry], xs[carry, c], rtol=0, atol=1e-11)
    np.testing.assert_allclose(res.gap, GAP * res.d, rtol=0, atol=1e-14)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("layout", ["wide_slave", "offset0.5"])
def test_partly_covered_rows_balance_with_masked_nodes(dim, layout):
    """Boundary-modified dual basis on top of the covered-part one: ``sum_q M_pq`` equals
    ``D_pp`` plus the coupling to the masked nodes on every row."""
    xs, fs, ns, xm, fm = _surfaces(dim, layout, seed=41 + dim)
    mask = np.isclose(xs[:, 0], 1.0)
    res = assemble_mortar(xs, fs, ns, xm, fm, slave_node_mask=mask, search_radius=0.05)
    np.testing.assert_array_equal(res.d[mask], 0.0)
    off = np.bincount(res.d_off_rows, weights=res.d_off_vals, minlength=len(xs))
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d + off, rtol=0, atol=1e-14)
    np.testing.assert_allclose(res.gap, GAP * (res.d + off), rtol=0, atol=1e-14)
    # what the masked nodes lose, their neighbours carry: D + off sums to the overlap
    assert (res.d + off).sum() == pytest.approx(_overlap(dim, layout), rel=1e-12)


def test_barely_covered_facets_are_left_out():
    """A master edge 1e-14 past slave nodes covers slivers of facets too thin for a dual
    basis of their own: those facets are left out, the rest still balances."""
    rng = np.random.default_rng(5)
    xs, fs = flat_surface(4, 0.0, 1.0, 0.0, rng, perturb=0.0)
    xm, fm = flat_surface(3, 0.5 - 1e-14, 1.2, GAP, rng, perturb=0.0, flip=True)
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    assert np.all(np.isfinite(res.m_vals)) and np.all(np.isfinite(res.d))
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, rtol=0, atol=1e-14)
    assert res.d.sum() == pytest.approx(0.25, rel=1e-12)
    assert res.covered_area[(res.covered_area > 0) & (res.covered_area < 1e-6)].size == 0


# ----------------------------------------------------------------------------- M^ rows
#: upper (slave) block's width and x offset over the 20 mm lower (master) block; the
#: slave has 9 facets across, and in the wide-slave and offset layouts a slave node lies
#: 0.15 slave facets beyond the master's edge x = 0: the straddling slave facet is 85 %
#: covered and both its nodes carry a multiplier.
BLOCKS = {
    "wide_slave": (0.03, -1.15 * 0.03 / 9),
    "wide_master": (0.012, 0.0043),
    "offset": (0.02, -1.15 * 0.02 / 9),
}


def _blocks(dim: int, layout: str, path: Path | None = None):
    """Lower (master) block 20 mm wide (and deep), upper (slave) block per ``BLOCKS``
    (in 3D also offset in z by 0.37 times the x offset)."""
    width, offset = BLOCKS[layout]
    if dim == 2:
        return shapes.two_blocks_2d(
            COMM,
            path,
            upper_width=width,
            upper_offset=offset,
            h_lower=0.02 / 7,
            h_upper=width / 9,
        )
    return shapes.two_boxes_3d(
        COMM,
        path,
        upper_width=width,
        upper_depth=width,
        upper_offset=(offset, 0.37 * offset),
        h_lower=0.02 / 4,
        h_upper=width / 5,
    )


def _block_overlap(dim: int, layout: str) -> float:
    """Measure of the overlap of the blocks' contact faces (exact)."""
    width, offset = BLOCKS[layout]
    out = 1.0
    for shift in (offset, 0.37 * offset)[: dim - 1]:
        out *= min(0.02, shift + width) - max(0.0, shift)
    return out


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("layout", ["wide_slave", "wide_master", "offset"])
def test_mhat_rows_sum_to_one(dim, layout):
    """Every assembled row of ``M^ = D^-1 M`` (slave dof, master dofs) sums to 1: a rigid
    translation of the master is one of the slave, partly covered nodes included."""
    md = _blocks(dim, layout)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {pg["lower"]: Isotropic(E=1e7, nu=0.3), pg["upper"]: Isotropic(E=1e7, nu=0.3)}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    itf = build_interface(m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"])
    rows, inv = np.unique(itf.qt_rows, return_inverse=True)
    sums = np.bincount(inv, weights=itf.qt_vals, minlength=rows.size)
    worst = COMM.allreduce(float(np.abs(sums - 1.0).max(initial=0.0)), op=MPI.MAX)
    n_rows = COMM.allreduce(rows.size, op=MPI.SUM)
    assert n_rows == dim * COMM.allreduce(itf.blocks.size, op=MPI.SUM)
    assert worst < 1e-12
    # the multiplier nodes carry the overlap's area (sum of D, all ranks)
    overlap = _block_overlap(dim, layout)
    d_total = COMM.allreduce(float(itf.D.sum()), op=MPI.SUM)
    assert d_total <= overlap * (1 + 1e-12)
    assert d_total > 0.9 * overlap


# ----------------------------------------------------------------------------- full runs
def _scene(dim: int, mesh: Path, friction: str) -> str:
    """Slave (upper) top: traction down, held sideways; master (lower) bottom clamped."""
    free = '[0.0, "free"]' if dim == 2 else '[0.0, "free", 0.0]'
    zero = "[0.0, 0.0]" if dim == 2 else "[0.0, 0.0, 0.0]"
    load = "[0.0, -3.0e4]" if dim == 2 else "[0.0, -3.0e4, 0.0]"
    text = f'format = 1\n[scene]\nname = "cover"\nmesh = "{mesh}"\ndimension = {dim}\n'
    text += '[analysis]\nkind = "static"\nload_steps = 2\n'
    for body in ("lower", "upper"):
        text += f'[[material]]\nname = "{body}"\nregions = ["{body}"]\nmodel = "isotropic"\n'
        text += "E = 1.0e7\nnu = 0.3\n"
    text += '[[contact]]\nname = "pair"\nslave = "upper_contact"\nmaster = "lower_contact"\n'
    text += f'friction = "{friction}"\n'
    text += "coefficient = 0.3\n" if friction == "coulomb" else ""
    text += f'[[dirichlet]]\nboundary = "bottom"\nvalue = {zero}\n'
    text += f'[[dirichlet]]\nboundary = "top"\nvalue = {free}\n'
    text += f'[[traction]]\nboundary = "top"\nvalue = {load}\n'
    return text + "[output]\nfields_every = 0\n"


def _history(out: Path) -> dict[str, np.ndarray]:
    """The numeric columns of ``out/history.csv`` (one contact pair: one row a step)."""
    rows = list(csv.reader(open(out / "history.csv")))
    numeric = [k for k, c in enumerate(rows[0]) if c not in ("step", "time", "pair")]
    return {rows[0][k]: np.array([float(r[k]) for r in rows[1:]]) for k in numeric}


RUNS = [
    (2, "wide_slave", "none"),
    (2, "wide_master", "none"),
    (2, "offset", "coulomb"),
    (3, "wide_slave", "none"),
    (3, "offset", "coulomb"),
]


@pytest.mark.parametrize(("dim", "layout", "friction"), RUNS)
def test_reactions_balance_the_load(tmp_shared_path, dim, layout, friction):
    mesh = _blocks(dim, layout, tmp_shared_path / "mesh.msh")
    scene = tmp_shared_path / "scene.toml"
    if COMM.rank == 0:
        scene.write_text(_scene(dim, Path(mesh), friction))
    COMM.barrier()
    out = tmp_shared_path / "out"
    res = run_scene(load_scene(scene), COMM, output=out, progress=False)
    assert res.status == "converged", res.summary.get("message")
    hist = _history(out)
    comps = "xyz"[:dim]
    load = np.stack([hist[f"load_{c}"] for c in comps], axis=1)
    total = load.copy()
    for name in hist:
        if name.startswith("reaction_") and name[-1] in comps and name[-2] == "_":
            total[:, comps.index(name[-1])] += hist[name]
    size = np.linalg.norm(load, axis=1).max()
    assert size > 0.0
    assert np.abs(total).max() < 1e-8 * size
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reactions"]["balance_defect_max"] < 1e-8
    # held vertically only by the contact: the contact's normal force is the load
    np.testing.assert_allclose(hist["normal_force"], -load[:, 1], rtol=1e-8, atol=1e-8 * size)
