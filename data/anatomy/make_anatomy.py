"""Rebuild the bone surfaces of data/anatomy/ from the myo-sim 0.2.3 wheel.

    pip download myo-sim==0.2.3 --no-deps -d wheel && unzip wheel/*.whl -d myosim
    python data/anatomy/make_anatomy.py myosim/myo_sim/models/meshes

The source surfaces are binary STL in metres, y up (checked: the femur is 0.45 m long
along y).  Changes made here: the two vertebrae are placed in the pose of the MyoSuite
model (L3 on L4, both in L4's body frame); every surface goes through
``bonecontact.meshing.prepare_surface`` (duplicate vertices merged, orientation made
consistent) and the tibia and mandible, which have holes and non-manifold edges, are
repaired (``repair=True``: pymeshfix); scale 1 (already metres).
"""

import math
import sys
from pathlib import Path

import meshio
import numpy as np

from bonecontact.meshing.surface_repair import Surface, prepare_surface, read_surface

HERE = Path(__file__).resolve().parent

#: shipped name: (source file, repair, rotation about z (rad), translation (m))
#: L4 mesh in L4's body frame: geom pos (-0.009, -0.004, 0), euler z -0.2;
#: L3 in L4's frame: body pos (0.0006, 0.0332, 0) plus geom pos (-0.004, -0.002, 0), euler z -0.1.
SURFACES = {
    "L3": ("lumbar3.stl", False, -0.1, (0.0006 - 0.004, 0.0332 - 0.002, 0.0)),
    "L4": ("lumbar4.stl", False, -0.2, (-0.009, -0.004, 0.0)),
    "femur": ("r_femur.stl", False, 0.0, (0.0, 0.0, 0.0)),
    "tibia": ("r_tibia.stl", True, 0.0, (0.0, 0.0, 0.0)),
    "mandible": ("hat_jaw.stl", True, 0.0, (0.0, -0.5, 0.0)),  # geom pos in the head frame
}


def place(surface: Surface, angle: float, shift) -> Surface:
    """Rotate about z by ``angle`` and translate by ``shift``."""
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Surface(surface.points @ rot.T + np.asarray(shift), surface.triangles, surface.source)


def main(source_dir: Path) -> None:
    for name, (file, repair, angle, shift) in SURFACES.items():
        raw = place(read_surface(source_dir / file), angle, shift)
        surface = prepare_surface(raw, repair=repair)
        meshio.write(
            HERE / f"{name}.stl",
            meshio.Mesh(surface.points, [("triangle", surface.triangles)]),
            binary=True,
        )
        print(
            f"{name}: {len(surface.triangles)} triangles, V = {surface.volume:.4g} m³, "
            f"A = {surface.area:.4g} m²; {'; '.join(surface.repairs) or 'no repair'}"
        )


if __name__ == "__main__":
    main(Path(sys.argv[1]))
