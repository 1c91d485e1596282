"""The shipped bone surfaces (bonecontact.meshing.anatomy_data): present, closed, in metres.

References: independent plausibility of human bone sizes (a femur 0.40-0.50 m long, a
lumbar vertebral body 30-50 mm tall with the processes, 60-80 mm wide) and the licence
files that must ship with them.
"""

import numpy as np
import pytest

from bonecontact.meshing import ANATOMY_SURFACES, MeshInputError, anatomy_surface
from bonecontact.meshing.anatomy_data import ANATOMY_DIR
from bonecontact.meshing.stl import inside_mask
from bonecontact.meshing.surface_repair import surface_defects


@pytest.mark.parametrize("name", list(ANATOMY_SURFACES))
def test_surface_is_closed_outward_and_in_metres(name):
    s = anatomy_surface(name)
    assert surface_defects(s) == []
    assert s.volume > 0
    extent = np.ptp(s.points, axis=0)
    assert 0.02 < extent.max() < 0.5  # metres, not millimetres


def test_sizes_are_human():
    femur = np.ptp(anatomy_surface("femur").points, axis=0)
    assert 0.40 < femur[1] < 0.50  # long axis along y (y up)
    l4 = np.ptp(anatomy_surface("L4").points, axis=0)
    assert 0.03 < l4[1] < 0.05 and 0.06 < l4[0] < 0.08


def test_vertebra_pair_is_stacked_without_overlap():
    l3, l4 = anatomy_surface("L3"), anatomy_surface("L4")
    assert l3.points[:, 1].mean() > l4.points[:, 1].mean() + 0.02  # L3 above L4
    # no vertex of L3 lies inside L4: a fine grid over L3's vertices' box
    lo, hi = l3.points.min(axis=0), l3.points.max(axis=0)
    axes = [np.linspace(lo[i], hi[i], 60) for i in range(3)]
    in3, in4 = inside_mask(l3, axes), inside_mask(l4, axes)
    assert in3.sum() > 1000
    assert not (in3 & in4).any()


def test_unknown_name_lists_the_available_ones():
    with pytest.raises(MeshInputError, match="available: L3, L4, femur, tibia, mandible"):
        anatomy_surface("skull")


def test_licence_and_notice_ship_with_the_data():
    assert "Apache License" in (ANATOMY_DIR / "LICENSE-Apache-2.0.txt").read_text()
    notice = (ANATOMY_DIR / "NOTICE").read_text()
    assert "myo-sim" in notice and "0.2.3" in notice
    assert anatomy_surface("jaw").volume == anatomy_surface("mandible").volume
