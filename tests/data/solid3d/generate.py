#!/usr/bin/env python3
"""Independent 3-D elasticity reference frequencies of free-free layered plates (CalculiX).

For every case (a rectangular layered plate and its bonded test configurations) this
script builds structured meshes of 20-node reduced-integration bricks (C3D20R), one or
more elements through every layer, orthotropic layer materials with their full 3-D
constants, and solves the free-free modes with ``ccx`` (CalculiX, SPOOLES + ARPACK).

Every layer's material axes are along the plate edges (0 or 90 deg), so the plate has two
mirror planes (x = L/2, y = W/2): a quarter model is solved four times, once per
symmetric/antisymmetric combination of the mirror conditions, and the four spectra are
merged (``SYMMETRY_CLASSES``).  The merge is checked once per case against a full model
(the coarse mesh, one configuration): same frequencies to the printed digits.

For every elastic mode the mid-surface (geometric mid-plane of the configuration's whole
stack, the plate models' reference surface) displacements w, u, v are interpolated with
the element's own shape functions on a 13 x 11 grid (x_i = L i / 12, y_j = W j / 10);
the mode is "flexural" when w carries most of its kinetic energy (integrated over the
3-D body), else "in-plane"; flexural modes get a nodal-line label "(nx,ny)" (sign changes
of w counted along the grid lines, ``nodal_label``, read on a finer 49 x 41 grid of w).

A mesh-convergence study (meshes in ``LEVELS``, refined in-plane and through the
thickness) gives the frequencies of every density; the finest mesh's are the reference,
and the relative change between the two finest is stored per mode.

Usage::

    python tests/data/solid3d/generate.py [--case NAME ...] [--quick] [--out DIR]

``--quick`` runs the coarsest mesh only (and writes into a temporary folder unless
``--out`` is given), to check the script.  Needs ``ccx`` on the PATH
(Debian: ``apt-get install calculix-ccx``); runs one ccx at a time with
OMP_NUM_THREADS=1 unless ``--threads`` says otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]

# ---------------------------------------------------------------------------------------
# Materials: full 3-D orthotropic constants in the material axes (GPa, kg/m^3).
# 1 = fibre / warp direction, 2 = in-plane transverse, 3 = through the thickness.
# Sources and reasons in README.md next to this file.
MATERIALS = {
    "cfrp_ud": dict(
        E1=130.0,
        E2=9.0,
        E3=9.0,
        G12=5.0,
        G13=5.0,
        G23=3.2,
        nu12=0.30,
        nu13=0.30,
        nu23=0.40,
        density=1560.0,
        note="T300/epoxy-like unidirectional ply, transversely isotropic (G23 = E2 / (2 (1 + nu23)) = 3.21)",
    ),
    "gfrp_ud": dict(
        E1=40.0,
        E2=10.0,
        E3=10.0,
        G12=4.0,
        G13=4.0,
        G23=3.5,
        nu12=0.28,
        nu13=0.28,
        nu23=0.43,
        density=1950.0,
        note="E-glass/epoxy unidirectional ply, transversely isotropic (G23 = E2 / (2 (1 + nu23)) = 3.50)",
    ),
    "cfrp_fabric": dict(
        E1=62.0,
        E2=60.0,
        E3=9.0,
        G12=4.8,
        G13=3.5,
        G23=3.5,
        nu12=0.05,
        nu13=0.30,
        nu23=0.30,
        density=1500.0,
        note="woven (plain/twill) carbon/epoxy skin",
    ),
    "pvc_foam": dict(
        E1=0.10,
        E2=0.10,
        E3=0.10,
        G12=0.035,
        G13=0.035,
        G23=0.035,
        nu12=0.10 / (2 * 0.035) - 1,
        nu13=0.10 / (2 * 0.035) - 1,
        nu23=0.10 / (2 * 0.035) - 1,
        density=80.0,
        note="cross-linked PVC foam core, H80-like, taken isotropic (nu = E / 2G - 1 = 0.4286)",
    ),
    "aluminium": dict(
        E1=70.0,
        E2=70.0,
        E3=70.0,
        G12=70.0 / 2.66,
        G13=70.0 / 2.66,
        G23=70.0 / 2.66,
        nu12=0.33,
        nu13=0.33,
        nu23=0.33,
        density=2700.0,
        note="aluminium alloy, isotropic (G = E / 2(1 + nu))",
    ),
    "soft_adhesive": dict(
        E1=1.0,
        E2=1.0,
        E3=1.0,
        G12=1.0 / 2.8,
        G13=1.0 / 2.8,
        G23=1.0 / 2.8,
        nu12=0.40,
        nu13=0.40,
        nu23=0.40,
        density=1150.0,
        note="flexible epoxy / polyurethane bond line, isotropic (G = E / 2(1 + nu))",
    ),
    "spruce": dict(
        E1=11.0,
        E2=0.90,
        E3=0.50,
        G12=0.70,
        G13=0.65,
        G23=0.040,
        nu12=0.37,
        nu13=0.42,
        nu23=0.47,
        density=450.0,
        note=(
            "quarter-sawn Norway spruce, 1 = longitudinal L, 2 = radial R, 3 = tangential T; ratios in the "
            "range of the Wood Handbook (USDA FPL, ch. 5) for spruce; rolling shear G23 = G_RT = E2 / 22.5 "
            "= G12 / 17.5"
        ),
    ),
}


def _bonded(plate_mm: float, adhesive_mm: float = 0.1):
    added = [("soft_adhesive", adhesive_mm, 0.0), ("aluminium", plate_mm, 0.0)]
    return [
        dict(name="original", bottom=[], top=[]),
        dict(name="al_bottom", bottom=added, top=[]),
        dict(name="al_top", bottom=[], top=added),
    ]


CASES = {
    "thick_laminate": dict(
        description=(
            "Symmetric 0-deg hybrid laminate GFRP/CFRP/GFRP, 6 mm thick (a/h = 33): transverse shear "
            "of the low-shear-modulus plies matters; bonded configurations add a soft 0.1 mm bond "
            "line and a 1 mm aluminium plate under or over it."
        ),
        length_mm=200.0,
        width_mm=150.0,
        layers=[("gfrp_ud", 1.5, 0.0), ("cfrp_ud", 3.0, 0.0), ("gfrp_ud", 1.5, 0.0)],
        configurations=_bonded(1.0),
    ),
    "laminate_on_adhesive": dict(
        description=(
            "Cross-ply CFRP(0)/GFRP(90)/CFRP(0), 5 mm thick; bonded configurations add a soft 0.1 mm "
            "bond line and a 2 mm aluminium plate, where the bond line's shear flexibility matters."
        ),
        length_mm=200.0,
        width_mm=150.0,
        layers=[("cfrp_ud", 1.25, 0.0), ("gfrp_ud", 2.5, 90.0), ("cfrp_ud", 1.25, 0.0)],
        configurations=_bonded(2.0),
    ),
    "foam_sandwich": dict(
        description=(
            "Sandwich of woven CFRP skins (0.5 mm) on a 6 mm PVC foam core: core shear dominates the "
            "higher modes (the case where single-layer plate theories are weakest); bonded "
            "configurations add a soft 0.1 mm bond line and a 1 mm aluminium plate."
        ),
        length_mm=250.0,
        width_mm=200.0,
        layers=[("cfrp_fabric", 0.5, 0.0), ("pvc_foam", 6.0, 0.0), ("cfrp_fabric", 0.5, 0.0)],
        configurations=_bonded(1.0),
    ),
    "spruce_plate": dict(
        description=(
            "A quarter-sawn spruce plate, 240 x 180 x 8 mm (a/h = 30 along the grain, 22.5 across), "
            "one layer, grain along the length: wood's rolling shear modulus G23 = G_RT is about 20x "
            "smaller than E2 and 17x smaller than G12, so transverse shear matters at moderate "
            "slenderness and the default G13 = G23 = G12 is badly wrong; bonded configurations add a "
            "soft 0.1 mm bond line and a 1 mm aluminium plate under or over it."
        ),
        length_mm=240.0,
        width_mm=180.0,
        layers=[("spruce", 8.0, 0.0)],
        configurations=_bonded(1.0),
    ),
    "thick_homogeneous": dict(
        description=(
            "Control: a homogeneous 150 x 100 x 8 mm aluminium plate (a/h = 19), where first-order "
            "shear deformation with k = 5/6 and rotary inertia is known to be excellent."
        ),
        length_mm=150.0,
        width_mm=100.0,
        layers=[("aluminium", 8.0, 0.0)],
        configurations=[dict(name="original", bottom=[], top=[])],
    ),
}


@dataclass(frozen=True)
class Level:
    """A mesh density: elements along the plate length (full plate; the width gets the
    nearest even count of near-square elements) and a factor on every layer's base
    number of elements through its thickness (``layer_elements``)."""

    name: str
    n_length: int
    thickness_factor: int


LEVELS = (Level("coarse", 24, 1), Level("medium", 36, 2), Level("fine", 48, 3))
#: Extra densities for trying the script out (``--levels``), not used for the references.
TRIAL_LEVELS = (Level("tiny", 12, 1),)
#: Base elements through a layer: one per started THICKNESS_UNIT_MM (at least one).
THICKNESS_UNIT_MM = 2.0
#: Elastic modes asked per symmetry class of the quarter model (plus its rigid-body modes).
ELASTIC_PER_CLASS = 8
#: The stored list: the lowest elastic modes up to the MIN_FLEXURAL-th flexural one, and
#: at least MIN_ELASTIC of them.
MIN_ELASTIC, MIN_FLEXURAL = 12, 16
#: Kinetic-energy share of w above which a mode is "flexural".
FLEXURAL_SHARE = 0.5
GRID = (13, 11)  # points along x, along y
#: A spec states E3 for a core whose E3 is at least this many times its in-plane moduli
#: (end-grain balsa, a honeycomb), the project's own class limit
#: (``identify.fitting.plausibility.THROUGH_THICKNESS_CORE``): a user who bonds such a core
#: knows what it is, and its E3 is on its data sheet.
THROUGH_THICKNESS_CORE = 5.0
LABEL_GRID = (49, 41)

#: The quarter model [0, L/2] x [0, W/2]; mirror planes x = L/2 and y = W/2.
#: Class "XY": X = S (symmetric) or A (antisymmetric) about x = L/2, Y likewise about y = W/2.
#: Symmetric about x = L/2: u = 0 there; antisymmetric: v = w = 0.  About y = W/2:
#: symmetric v = 0, antisymmetric u = w = 0.  Rigid-body modes per class: SS Tz;
#: SA Ty, Rx; AS Tx, Ry; AA Rz.
SYMMETRY_CLASSES = {"SS": 1, "SA": 2, "AS": 2, "AA": 1}


# ---------------------------------------------------------------------------------------
# Geometry and mesh


def stack(case: dict, configuration: dict) -> list[tuple[str, float, float]]:
    """The configuration's full stack bottom to top: (material, thickness_mm, angle_deg)."""
    return list(reversed(configuration["bottom"])) + list(case["layers"]) + list(configuration["top"])


def layer_elements(thickness_mm: float, factor: int) -> int:
    return factor * max(1, math.ceil(thickness_mm / THICKNESS_UNIT_MM - 1e-9))


@dataclass
class Mesh:
    """A structured C3D20R mesh of [0, lx] x [0, ly] x [0, H] (mm)."""

    lx: float
    ly: float
    nx: int
    ny: int
    z_levels: np.ndarray  # element boundaries through the thickness (nz + 1,)
    element_layer: np.ndarray  # layer index of every element row through the thickness (nz,)
    x_lines: np.ndarray | None = None  # element boundaries along x (nx + 1,); None: equal elements
    y_lines: np.ndarray | None = None

    @property
    def nz(self) -> int:
        return len(self.z_levels) - 1

    @property
    def xs(self) -> np.ndarray:
        """Element boundaries along x (nx + 1,) [mm]."""
        return np.linspace(0.0, self.lx, self.nx + 1) if self.x_lines is None else np.asarray(self.x_lines)

    @property
    def ys(self) -> np.ndarray:
        return np.linspace(0.0, self.ly, self.ny + 1) if self.y_lines is None else np.asarray(self.y_lines)

    def element_areas(self) -> np.ndarray:
        """In-plane area of every element (order of ``elements``) [mm^2]."""
        area = np.outer(np.diff(self.ys), np.diff(self.xs)).ravel()  # y rows, x fastest
        return np.tile(area, self.nz)

    def lattice(self):
        """Node ids on the quadratic lattice (2nx+1, 2ny+1, 2nz+1), -1 where no node
        (face and body centres), and the coordinates of the nodes in id order."""
        xs, ys = (_with_midpoints(a) for a in (self.xs, self.ys))
        zm = 0.5 * (self.z_levels[:-1] + self.z_levels[1:])
        zs = np.empty(2 * self.nz + 1)
        zs[0::2], zs[1::2] = self.z_levels, zm
        i, j, k = np.meshgrid(np.arange(xs.size), np.arange(ys.size), np.arange(zs.size), indexing="ij")
        used = (i % 2 + j % 2 + k % 2) <= 1
        ids = -np.ones(i.shape, dtype=np.int64)
        ids[used] = np.arange(1, used.sum() + 1)
        coords = np.column_stack([xs[i[used]], ys[j[used]], zs[k[used]]])
        return ids, coords

    def elements(self, ids: np.ndarray) -> np.ndarray:
        """(n_elements, 20) node ids in ccx/Abaqus C3D20 order; elements numbered with x
        fastest, then y, then z."""
        ex, ey, ez = np.meshgrid(np.arange(self.nx), np.arange(self.ny), np.arange(self.nz), indexing="ij")
        ex, ey, ez = (a.transpose(2, 1, 0).ravel() for a in (ex, ey, ez))  # x fastest
        offsets = (NATURAL + 1).astype(int)
        return ids[
            2 * ex[:, None] + offsets[:, 0], 2 * ey[:, None] + offsets[:, 1], 2 * ez[:, None] + offsets[:, 2]
        ]

    def locate(self, x: float, y: float, z: float) -> tuple[int, np.ndarray]:
        """Element number (0-based, order of ``elements``) holding the point, and its
        natural coordinates (xi, eta, zeta) in [-1, 1]."""
        xs, ys = self.xs, self.ys
        ex = int(np.clip(np.searchsorted(xs, x, side="right") - 1, 0, self.nx - 1))
        ey = int(np.clip(np.searchsorted(ys, y, side="right") - 1, 0, self.ny - 1))
        ez = int(np.clip(np.searchsorted(self.z_levels, z, side="right") - 1, 0, self.nz - 1))
        z0, z1 = self.z_levels[ez], self.z_levels[ez + 1]
        natural = np.array(
            [
                2 * (x - xs[ex]) / (xs[ex + 1] - xs[ex]) - 1,
                2 * (y - ys[ey]) / (ys[ey + 1] - ys[ey]) - 1,
                2 * (z - z0) / (z1 - z0) - 1,
            ]
        )
        return (ez * self.ny + ey) * self.nx + ex, natural


def _with_midpoints(lines: np.ndarray) -> np.ndarray:
    """Element boundaries and the mid-side positions between them (2n + 1,)."""
    out = np.empty(2 * len(lines) - 1)
    out[0::2], out[1::2] = lines, 0.5 * (lines[:-1] + lines[1:])
    return out


#: Natural coordinates of the 20 nodes of C3D20 in ccx/Abaqus order.
NATURAL = np.array(
    [
        [-1, -1, -1],
        [1, -1, -1],
        [1, 1, -1],
        [-1, 1, -1],
        [-1, -1, 1],
        [1, -1, 1],
        [1, 1, 1],
        [-1, 1, 1],
        [0, -1, -1],
        [1, 0, -1],
        [0, 1, -1],
        [-1, 0, -1],
        [0, -1, 1],
        [1, 0, 1],
        [0, 1, 1],
        [-1, 0, 1],
        [-1, -1, 0],
        [1, -1, 0],
        [1, 1, 0],
        [-1, 1, 0],
    ],
    dtype=float,
)


def shape_functions(points: np.ndarray) -> np.ndarray:
    """20-node serendipity shape functions at natural points (n, 3) -> (n, 20)."""
    p = np.atleast_2d(points)[:, None, :]
    a = NATURAL[None, :, :]
    one = 1 + p * a  # (n, 20, 3)
    corner = np.prod(one, axis=2) * (np.sum(p * a, axis=2) - 2) / 8
    out = np.empty(corner.shape)
    is_corner = np.all(NATURAL != 0, axis=1)
    out[:, is_corner] = corner[:, is_corner]
    for axis in range(3):
        mid = NATURAL[:, axis] == 0
        others = [b for b in range(3) if b != axis]
        out[:, mid] = (
            (1 - p[:, 0, axis : axis + 1] ** 2)
            * one[:, mid][:, :, others[0]]
            * one[:, mid][:, :, others[1]]
            / 4
        )
    return out


def build_mesh(case: dict, layers, level: Level, quarter: bool) -> Mesh:
    length, width = case["length_mm"], case["width_mm"]
    nx = level.n_length
    ny = max(2, 2 * round(nx * width / length / 2))
    z, rows = [0.0], []
    for index, (_, thickness, _) in enumerate(layers):
        n = layer_elements(thickness, level.thickness_factor)
        z.extend(z[-1] + thickness * np.arange(1, n + 1) / n)
        rows.extend([index] * n)
    z_levels = np.array(z)
    if quarter:
        return Mesh(length / 2, width / 2, nx // 2, ny // 2, z_levels, np.array(rows))
    return Mesh(length, width, nx, ny, z_levels, np.array(rows))


# ---------------------------------------------------------------------------------------
# ccx input, run and results


def write_input(
    path: Path,
    mesh: Mesh,
    layers,
    boundary: str | None,
    n_eigen: int,
    materials=None,
    extra: tuple[str, ...] = (),
    heavier: tuple[np.ndarray, float] | None = None,
) -> None:
    """A ccx deck: nodes, C3D20R elements by layer, materials (mm, N, t, s -> MPa, t/mm^3;
    ``materials`` defaults to ``MATERIALS``), orientations for turned plies, mirror
    conditions of a symmetry class, ``extra`` model lines (e.g. a point mass), *FREQUENCY.
    ``heavier``: (element indices of one layer, 0-based, added density [kg/m^3]): those
    elements in a set of their own, of their layer's material with that much more density
    (a sensor's mass spread over the elements under its base)."""
    materials = MATERIALS if materials is None else materials
    ids, coords = mesh.lattice()
    elements = mesh.elements(ids)
    lines = ["*HEADING", f"layer-id 3-D reference, {path.stem}", "*NODE"]
    lines += [f"{n},{x:.10g},{y:.10g},{z:.10g}" for n, (x, y, z) in enumerate(coords, start=1)]
    per_layer = mesh.nx * mesh.ny
    element_layer = np.repeat(mesh.element_layer, per_layer)
    heavy = set() if heavier is None else {int(e) for e in heavier[0]}
    sets = [
        (f"LAYER{index + 1}", index, [e for e in np.nonzero(element_layer == index)[0] if e not in heavy])
        for index in range(len(layers))
    ]
    if heavy:
        sets.append(("SENSOR", int(element_layer[min(heavy)]), sorted(heavy)))
    for elset, _, members in sets:
        lines.append(f"*ELEMENT, TYPE=C3D20R, ELSET={elset}")
        for e in members:
            nodes = elements[e]
            lines.append(f"{e + 1}," + ",".join(map(str, nodes[:15])) + ",")
            lines.append(",".join(map(str, nodes[15:])))
    kinds = [(name, name.upper(), 0.0) for name in sorted({m for m, _, _ in layers})]
    if heavy:
        kinds.append((layers[sets[-1][1]][0], "SENSOR_BASE", heavier[1]))
    for name, label, added in kinds:
        c = materials[name]
        lines += [
            f"*MATERIAL, NAME={label}",
            "*ELASTIC, TYPE=ENGINEERING CONSTANTS",
            ",".join(
                f"{v:.10g}"
                for v in (
                    1e3 * c["E1"],
                    1e3 * c["E2"],
                    1e3 * c["E3"],
                    c["nu12"],
                    c["nu13"],
                    c["nu23"],
                    1e3 * c["G12"],
                    1e3 * c["G13"],
                )
            ),
            f"{1e3 * c['G23']:.10g}",
            "*DENSITY",
            f"{(c['density'] + added) * 1e-12:.10g}",
        ]
    for elset, index, _ in sets:
        name, _, angle = layers[index]
        option = ""
        if angle != 0.0:
            a = math.radians(angle)
            lines += [
                f"*ORIENTATION, NAME=OR{elset}, SYSTEM=RECTANGULAR",
                f"{math.cos(a):.12g},{math.sin(a):.12g},0,{-math.sin(a):.12g},{math.cos(a):.12g},0",
            ]
            option = f", ORIENTATION=OR{elset}"
        material = "SENSOR_BASE" if elset == "SENSOR" else name.upper()
        lines.append(f"*SOLID SECTION, ELSET={elset}, MATERIAL={material}{option}")
    if boundary is not None:
        on_x = ids[-1, :, :][ids[-1, :, :] > 0]  # x = lx (the mirror plane x = L/2)
        on_y = ids[:, -1, :][ids[:, -1, :] > 0]
        for name, nodes in (("MIRRORX", on_x), ("MIRRORY", on_y)):
            lines.append(f"*NSET, NSET={name}")
            lines += [",".join(map(str, nodes[i : i + 16])) for i in range(0, len(nodes), 16)]
        sx, sy = boundary
        lines.append("*BOUNDARY")
        lines += ["MIRRORX,1,1"] if sx == "S" else ["MIRRORX,2,3"]
        lines += ["MIRRORY,2,2"] if sy == "S" else ["MIRRORY,1,1", "MIRRORY,3,3"]
    lines += [*extra, "*STEP", "*FREQUENCY", f"{n_eigen}", "*NODE FILE", "U", "*END STEP", ""]
    path.write_text("\n".join(lines))


def run_ccx(job: Path, threads: int) -> float:
    env = dict(
        os.environ,
        OMP_NUM_THREADS=str(threads),
        CCX_NPROC_EQUATION_SOLVER=str(threads),
        CCX_NPROC_STIFFNESS=str(threads),
        CCX_NPROC_RESULTS=str(threads),
    )
    start = time.perf_counter()
    result = subprocess.run(["ccx", "-i", job.name], cwd=job.parent, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    (job.parent / f"{job.name}.log").write_text(result.stdout + result.stderr)
    if result.returncode != 0 or "*ERROR" in result.stdout:
        tail = "\n".join((result.stdout + result.stderr).splitlines()[-20:])
        raise RuntimeError(f"ccx failed on {job}.inp:\n{tail}")
    return wall


def read_eigenvalues(dat: Path) -> np.ndarray:
    """omega^2 [rad^2/s^2] of every mode from the .dat eigenvalue table."""
    text = dat.read_text().splitlines()
    start = next(i for i, line in enumerate(text) if "E I G E N V A L U E   O U T P U T" in line)
    values = []
    for line in text[start + 1 :]:
        parts = line.split()
        if "P A R T I C I P A T I O N" in line:
            break
        if len(parts) == 5 and parts[0].isdigit():
            values.append(float(parts[1]))
    return np.array(values)


def read_displacements(frd: Path, n_nodes: int) -> np.ndarray:
    """(modes, n_nodes, 3) nodal displacements of every mode from the ASCII .frd."""
    modes, current = [], None
    with frd.open() as handle:
        for line in handle:
            if line.startswith(" -4  DISP"):
                current = np.zeros((n_nodes, 3))
            elif current is not None and line.startswith(" -1"):
                node = int(line[3:13])
                current[node - 1] = (float(line[13:25]), float(line[25:37]), float(line[37:49]))
            elif current is not None and line.startswith(" -3"):
                modes.append(current)
                current = None
    return np.array(modes)


def ccx_version() -> str:
    result = subprocess.run(["ccx", "-v"], capture_output=True, text=True)
    match = re.search(r"Version\s+([\d.]+)", result.stdout + result.stderr)
    return f"CalculiX {match.group(1)}" if match else "CalculiX (version unknown)"


# ---------------------------------------------------------------------------------------
# Post-processing


@dataclass
class Solved:
    """The modes of one (quarter or full) run, kept for sampling."""

    mesh: Mesh
    elements: np.ndarray  # (ne, 20) node ids
    eigenvalues: np.ndarray  # elastic only
    displacements: np.ndarray  # (modes, n_nodes, 3), elastic only
    cls: str | None  # symmetry class or None for a full model
    w_share: np.ndarray
    wall_s: float


_GAUSS3 = np.polynomial.legendre.leggauss(3)


def kinetic_shares(mesh: Mesh, elements: np.ndarray, densities: np.ndarray, disp: np.ndarray) -> np.ndarray:
    """Share of the kinetic energy carried by w, int rho w^2 / int rho |u|^2, per mode
    (3 x 3 x 3 Gauss points per element; elements are boxes)."""
    g, wg = _GAUSS3
    pts = np.array([[a, b, c] for a in g for b in g for c in g])
    wts = np.array([a * b * c for a in wg for b in wg for c in wg])
    n = shape_functions(pts)  # (27, 20)
    hz = np.diff(mesh.z_levels)
    per_layer = mesh.nx * mesh.ny
    volume = np.repeat(hz, per_layer) * mesh.element_areas() / 8  # det J
    weight = densities * volume
    shares = []
    for d in disp:
        at = np.einsum("qa,eac->eqc", n, d[elements - 1])
        energy = np.einsum("e,q,eqc->c", weight, wts, at * at)
        shares.append(energy[2] / energy.sum())
    return np.array(shares)


def sample(solved: Solved, case: dict, z_mid: float, nx: int, ny: int) -> np.ndarray:
    """(modes, 3, ny, nx): u, v, w at the mid-plane on the grid x_i = L i/(nx-1),
    y_j = W j/(ny-1) of the full plate, mirrored from the quarter model when needed."""
    length, width = case["length_mm"], case["width_mm"]
    xs = length * np.arange(nx) / (nx - 1)
    ys = width * np.arange(ny) / (ny - 1)
    out = np.zeros((len(solved.eigenvalues), 3, ny, nx))
    for j, y0 in enumerate(ys):
        for i, x0 in enumerate(xs):
            x, y, factor = x0, y0, np.ones(3)
            if solved.cls is not None:
                sx, sy = (1.0 if c == "S" else -1.0 for c in solved.cls)
                if x > length / 2 + 1e-9:
                    x = length - x
                    factor *= np.array([-sx, sx, sx])
                if y > width / 2 + 1e-9:
                    y = width - y
                    factor *= np.array([sy, -sy, sy])
            e, natural = solved.mesh.locate(x, y, z_mid)
            n = shape_functions(natural)[0]
            values = np.einsum("a,mac->mc", n, solved.displacements[:, solved.elements[e] - 1])
            out[:, :, j, i] = values * factor
    return out


def nodal_label(w: np.ndarray) -> str:
    """ "(nx,ny)": nodal lines crossed along x and along y (signs where |w| > 5 % of max,
    sign changes counted per grid line, median)."""
    significant = np.where(np.abs(w) > 0.05 * np.abs(w).max(), np.sign(w), 0)

    def crossings(rows: np.ndarray) -> int:
        counts = []
        for row in rows:
            signs = row[row != 0]
            counts.append(int(np.sum(signs[1:] != signs[:-1])))
        return int(np.median(counts))

    return f"({crossings(significant)},{crossings(significant.T)})"


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC matrix of the columns of a and b (flattened shapes)."""
    num = (a.T @ b) ** 2
    return num / np.outer(np.einsum("ij,ij->j", a, a), np.einsum("ij,ij->j", b, b))


# ---------------------------------------------------------------------------------------
# Solving one configuration on one mesh


def solve(
    case: dict, layers, level: Level, workdir: Path, tag: str, threads: int, quarter: bool = True, log=print
) -> dict:
    """Every elastic mode found (merged from the four quarter runs, or the full model),
    sorted, with the complete range only: frequencies, w-shares, grid shapes, labels."""
    classes = list(SYMMETRY_CLASSES) if quarter else [None]
    densities_by_layer = np.array([MATERIALS[m]["density"] * 1e-12 for m, _, _ in layers])
    runs, wall = [], 0.0
    for cls in classes:
        mesh = build_mesh(case, layers, level, quarter)
        n_rigid = SYMMETRY_CLASSES[cls] if cls else 6
        n_elastic = ELASTIC_PER_CLASS if cls else 4 * ELASTIC_PER_CLASS
        job = workdir / f"{tag}_{cls or 'full'}"
        write_input(job.with_suffix(".inp"), mesh, layers, cls, n_rigid + n_elastic)
        seconds = run_ccx(job, threads)
        wall += seconds
        lam = read_eigenvalues(job.with_suffix(".dat"))
        ids, coords = mesh.lattice()
        elements = mesh.elements(ids)
        disp = read_displacements(job.with_suffix(".frd"), len(coords))
        if len(disp) != len(lam):
            raise RuntimeError(f"{job}: {len(lam)} eigenvalues but {len(disp)} mode shapes in the .frd")
        order = np.argsort(lam)
        lam, disp = lam[order], disp[order]
        rigid, elastic = lam[:n_rigid], lam[n_rigid:]
        if np.abs(rigid).max() > 1e-6 * elastic[0]:
            raise RuntimeError(
                f"{job}: the {n_rigid} lowest modes are not rigid-body modes "
                f"(omega^2 {rigid} vs first elastic {elastic[0]:.6g})"
            )
        densities = np.repeat(densities_by_layer[mesh.element_layer], mesh.nx * mesh.ny)
        shares = kinetic_shares(mesh, elements, densities, disp[n_rigid:])
        runs.append(Solved(mesh, elements, elastic, disp[n_rigid:], cls, shares, seconds))
        log(
            f"    {tag} {cls or 'full'}: {len(coords)} nodes, {len(elements)} elements, "
            f"{3 * len(coords)} DOFs, {seconds:.1f} s"
        )
    complete = min(r.eigenvalues.max() for r in runs)  # every mode below this was found
    z_mid = sum(t for _, t, _ in layers) / 2
    modes = []
    for r in runs:
        grid = sample(r, case, z_mid, *GRID)
        fine = sample(r, case, z_mid, *LABEL_GRID)
        for k, lam in enumerate(r.eigenvalues):
            if lam > complete * (1 + 1e-12):
                continue
            modes.append(
                dict(lam=lam, share=float(r.w_share[k]), cls=r.cls, grid=grid[k], label_w=fine[k, 2])
            )
    modes.sort(key=lambda m: m["lam"])
    for m in modes:
        m["frequency_hz"] = math.sqrt(max(m["lam"], 0.0)) / (2 * math.pi)
        m["classification"] = "flexural" if m["share"] > FLEXURAL_SHARE else "in-plane"
        m["label"] = nodal_label(m["label_w"]) if m["classification"] == "flexural" else "in-plane"
    n_flexural = sum(m["classification"] == "flexural" for m in modes)
    if len(modes) < MIN_ELASTIC or n_flexural < MIN_FLEXURAL:
        raise RuntimeError(
            f"{tag}: only {len(modes)} elastic ({n_flexural} flexural) modes complete; "
            f"raise ELASTIC_PER_CLASS"
        )
    dofs = sum(3 * len(r.mesh.lattice()[1]) for r in runs)
    return dict(
        modes=modes,
        wall_s=wall,
        mesh=dict(
            level=level.name,
            elements_along_length=level.n_length,
            elements_along_width=max(2, 2 * round(level.n_length * case["width_mm"] / case["length_mm"] / 2)),
            elements_through_layers=[layer_elements(t, level.thickness_factor) for _, t, _ in layers],
            model="quarter, 4 symmetry classes" if quarter else "full",
            dofs_total=dofs,
        ),
    )


# ---------------------------------------------------------------------------------------
# A case: every configuration at every density


def _sig(x: float, digits: int = 7) -> float:
    return float(f"{x:.{digits}g}")


def _grid_list(a: np.ndarray, digits: int = 5) -> list:
    """Rows of a normalised shape, 5 significant digits, round-off (< 1e-8) as 0."""
    return [[_sig(v, digits) + 0.0 if abs(v) >= 1e-8 else 0.0 for v in row] for row in a]


def spec_toml(name: str, case: dict, materials=None) -> str:
    """A project spec (the spec format of the docs) with the true properties (``materials``
    defaults to ``MATERIALS``)."""
    materials = MATERIALS if materials is None else materials
    used = []
    for m, _, _ in case["layers"]:
        if m not in used:
            used.append(m)
    added = []
    for c in case["configurations"]:
        for m, _, _ in c["bottom"] + c["top"]:
            if m not in used and m not in added:
                added.append(m)

    def layer(m, t, a):
        return f'{{ material = "{m}", thickness_mm = {t:g}, angle_deg = {a:g} }}'

    lines = [
        "[specimen]",
        f'name = "{name}"',
        f"length_mm = {case['length_mm']:g}",
        f"width_mm = {case['width_mm']:g}",
        "layers = [   # bottom to top",
    ]
    lines += [f"  {layer(*l)}," for l in case["layers"]]
    lines += ["]", ""]
    for m in used + added:
        c = materials[m]
        lines += [
            f"[materials.{m}]",
            f"E1_GPa = {_sig(c['E1'])!r}",
            f"E2_GPa = {_sig(c['E2'])!r}",
            f"G12_GPa = {_sig(c['G12'])!r}",
            f"nu12 = {_sig(c['nu12'])!r}",
            f"density_kg_m3 = {_sig(c['density'])!r}",
            f"G13_GPa = {_sig(c['G13'])!r}",
            f"G23_GPa = {_sig(c['G23'])!r}",
        ]
        if c["E3"] >= THROUGH_THICKNESS_CORE * max(c["E1"], c["E2"]):
            # a core whose grain or cells run through its thickness: a user states its E3
            lines.append(f"E3_GPa = {_sig(c['E3'])!r}")
        lines += [
            f"identify = {'true' if m in used else 'false'}",
            f'note = "3-D: E3 = {c["E3"]:g} GPa, nu13 = {c["nu13"]:.4g}, nu23 = {c["nu23"]:.4g}"',
            "",
        ]
    for c in case["configurations"]:
        lines += ["[[configurations]]", f'name = "{c["name"]}"']
        for side in ("bottom", "top"):
            if c[side]:
                lines.append(f"{side} = [ " + ", ".join(layer(*l) for l in c[side]) + " ]")
        lines.append("")
    lines += ["[model]", "modes = 10", ""]
    return "\n".join(lines)


def check_spec(text: str) -> None:
    """The spec must load with the project's own loader."""
    sys.path.insert(0, str(ROOT))
    from fem.spec import parse_spec  # noqa: PLC0415

    parse_spec(tomllib.loads(text), "<solid3d>")


def match_to(reference: list[dict], other: list[dict]) -> list[int | None]:
    """For each reference mode, the index of the other mesh's mode of the same shape
    (MAC of w, u, v on the grid, optimal assignment), None when MAC < 0.8."""
    from scipy.optimize import linear_sum_assignment  # noqa: PLC0415

    a = np.array([m["grid"].ravel() for m in reference]).T
    b = np.array([m["grid"].ravel() for m in other]).T
    macs = mac(a, b)
    rows, cols = linear_sum_assignment(-macs)
    out: list[int | None] = [None] * len(reference)
    for r, c in zip(rows, cols):
        if macs[r, c] >= 0.8:
            out[r] = int(c)
    return out


def mirror_twin(case: dict, configuration: dict, solved: dict) -> dict | None:
    """An already solved configuration whose stack is this one's mirror image through the
    thickness (z -> H - z), e.g. al_top of a symmetric specimen and al_bottom; or None."""
    mine = stack(case, configuration)
    for other in case["configurations"]:
        if other["name"] in solved and other["name"] != configuration["name"]:
            if list(reversed(stack(case, other))) == mine and stack(case, other) != mine:
                return other
    return None


def mirrored(result: dict) -> dict:
    """The modes of the z-mirrored stack: same frequencies, symmetry classes and energy
    shares; at the mid-plane (u, v, w) -> (u, v, -w)."""
    flip = np.array([1.0, 1.0, -1.0])[:, None, None]
    modes = [dict(m, grid=m["grid"] * flip, label_w=-m["label_w"]) for m in result["modes"]]
    mesh = dict(
        result["mesh"],
        model=result["mesh"]["model"] + "; z-mirror of the twin configuration's solution",
        elements_through_layers=result["mesh"]["elements_through_layers"][::-1],
    )
    return dict(modes=modes, wall_s=0.0, mesh=mesh)


def convergence_summary(modes: list[dict], levels) -> dict:
    """Largest relative change between the two finest meshes over the first 10 elastic
    and the first 10 flexural modes."""
    if len(levels) < 2:
        return {}

    def worst(selection):
        changes = [
            abs(m["relative_change_last_two"]) for m in selection if m["relative_change_last_two"] is not None
        ]
        return _sig(max(changes), 3) if len(changes) == len(selection) else None

    flexural = [m for m in modes if m["classification"] == "flexural"][:10]
    return dict(
        between=[levels[-2].name, levels[-1].name],
        max_abs_change_first10_elastic=worst(modes[:10]),
        max_abs_change_first10_flexural=worst(flexural),
    )


def dumps(data) -> str:
    """JSON with every innermost list of numbers on one line."""
    text = json.dumps(data, indent=1)
    return re.sub(
        r"\[\s*([-+0-9.eE,\s]+?)\s*\]",
        lambda m: "[" + ", ".join(m.group(1).split()).replace(",,", ",") + "]",
        text,
    )


def run_case(name: str, levels, workdir: Path, threads: int, verify_full: bool, log=print) -> dict:
    case = CASES[name]
    started = time.perf_counter()
    out = dict(
        case=name,
        description=case["description"],
        made_with=dict(
            solver=ccx_version(),
            element="C3D20R (20-node hexahedron, reduced integration 2x2x2)",
            eigensolver="ARPACK shift-invert (ccx *FREQUENCY, SPOOLES), free-free, no boundary conditions "
            "on the full plate",
            symmetry="quarter model [0, L/2] x [0, W/2], four mirror-condition classes merged (every layer's "
            "material axes along the plate edges)",
            script="tests/data/solid3d/generate.py",
            threads=threads,
            levels=[
                dict(name=l.name, elements_along_length=l.n_length, thickness_factor=l.thickness_factor)
                for l in levels
            ],
            thickness_rule=f"elements through a layer = factor x max(1, ceil(t / {THICKNESS_UNIT_MM:g} mm))",
            mid_surface="geometric mid-plane of each configuration's whole stack "
            "(the plate models' reference surface); u, v, w interpolated with the element shape functions",
            grid=dict(
                nx=GRID[0],
                ny=GRID[1],
                x="x_i = L i / 12",
                y="y_j = W j / 10",
                layout="shapes are [row j (y)][column i (x)]",
            ),
            normalisation="flexural modes: max |w| = 1 on the grid, largest w positive; in-plane modes: "
            "max(|u|, |v|) = 1, largest positive",
            classification=f"flexural when w carries more than {FLEXURAL_SHARE:g} of the kinetic energy "
            "(integrated over the 3-D body), else in-plane",
            nodal_lines="(nx,ny): nodal lines of w crossed along x and along y, read on a 49 x 41 mid-plane "
            "grid (sign changes of w counted per grid line, median)",
        ),
        plate=dict(length_mm=case["length_mm"], width_mm=case["width_mm"]),
        layers=[dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in case["layers"]],
        materials={},
        configurations=[],
    )
    used = []
    for c in [dict(bottom=[], top=[], name="")] + case["configurations"]:
        for m, _, _ in stack(case, c):
            if m not in used:
                used.append(m)
    for m in used:
        c = MATERIALS[m]
        out["materials"][m] = {
            **{f"{k}_GPa": _sig(c[k]) for k in ("E1", "E2", "E3", "G12", "G13", "G23")},
            **{k: _sig(c[k]) for k in ("nu12", "nu13", "nu23")},
            "density_kg_m3": c["density"],
            "note": c["note"],
        }
    timings, solved, mirror_checks = [], {}, []
    for configuration in case["configurations"]:
        layers = stack(case, configuration)
        log(
            f"  {name} / {configuration['name']}: {len(layers)} layers, H = {sum(t for _, t, _ in layers):g} "
            "mm"
        )
        twin = mirror_twin(case, configuration, solved)
        results = []
        for index, level in enumerate(levels):
            if twin is not None and index == len(levels) - 1 and len(levels) > 1:
                # The finest mesh of a configuration that is the exact z-mirror of one
                # already solved: its modes are the twin's, mirrored (checked on the
                # coarser meshes, which are solved independently).
                results.append(mirrored(solved[twin["name"]][index]))
                log(f"    {configuration['name']} {level.name}: the z-mirror of {twin['name']}")
                continue
            tag = f"{name}_{configuration['name']}_{level.name}"
            results.append(solve(case, layers, level, workdir, tag, threads, log=log))
            timings.append(
                dict(
                    configuration=configuration["name"],
                    level=level.name,
                    wall_s=round(results[-1]["wall_s"], 1),
                    dofs=results[-1]["mesh"]["dofs_total"],
                )
            )
            if twin is not None:
                mine = np.array([m["frequency_hz"] for m in results[-1]["modes"][:20]])
                theirs = np.array([m["frequency_hz"] for m in solved[twin["name"]][index]["modes"][:20]])
                difference = float(np.max(np.abs(mine / theirs - 1)))
                mirror_checks.append(
                    dict(
                        configuration=configuration["name"],
                        twin=twin["name"],
                        level=level.name,
                        modes_compared=len(mine),
                        max_relative_difference=_sig(difference, 3),
                    )
                )
                log(
                    f"    {configuration['name']} vs its mirror twin {twin['name']} ({level.name}): "
                    f"max rel. difference {difference:.2e}"
                )
        solved[configuration["name"]] = results
        finest = results[-1]["modes"]
        matches = [match_to(finest, r["modes"]) for r in results]
        flexural_ranks = [k for k, m in enumerate(finest) if m["classification"] == "flexural"]
        stored = max(MIN_ELASTIC, flexural_ranks[MIN_FLEXURAL - 1] + 1)
        modes = []
        for k, m in enumerate(finest):
            per_level = []
            for r, match in zip(results, matches):
                j = match[k]
                per_level.append(None if j is None else _sig(r["modes"][j]["frequency_hz"]))
            change = None
            if len(levels) > 1 and per_level[-2] is not None:
                change = _sig((per_level[-2] - per_level[-1]) / per_level[-1], 3)
            u, v, w = m["grid"]
            if m["classification"] == "flexural":
                scale = w.flat[np.argmax(np.abs(w))]
            else:
                uv = np.concatenate([u.ravel(), v.ravel()])
                scale = uv[np.argmax(np.abs(uv))]
            if k >= stored:
                break
            modes.append(
                dict(
                    rank=k + 1,
                    frequency_hz=_sig(m["frequency_hz"]),
                    frequencies_by_level=dict(zip((l.name for l in levels), per_level)),
                    relative_change_last_two=change,
                    classification=m["classification"],
                    w_share=_sig(m["share"], 5),
                    label=m["label"],
                    symmetry_class=m["cls"],
                    w=_grid_list(w / scale),
                    u=_grid_list(u / scale),
                    v=_grid_list(v / scale),
                )
            )
        out["configurations"].append(
            dict(
                name=configuration["name"],
                bottom=[dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in configuration["bottom"]],
                top=[dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in configuration["top"]],
                total_thickness_mm=_sig(sum(t for _, t, _ in layers)),
                mid_surface_z_mm=_sig(sum(t for _, t, _ in layers) / 2),
                meshes=[r["mesh"] for r in results],
                convergence=convergence_summary(modes, levels),
                modes=modes,
            )
        )
    if mirror_checks:
        out["made_with"]["mirror_checks"] = mirror_checks
    if verify_full:
        configuration = case["configurations"][-1]
        layers = stack(case, configuration)
        level = levels[0]
        log(f"  {name} / {configuration['name']}: full-model check on the {level.name} mesh")
        quarter = solved[configuration["name"]][0]
        full = solve(case, layers, level, workdir, f"{name}_check_full", threads, quarter=False, log=log)
        n = min(len(quarter["modes"]), len(full["modes"]), 20)
        fq = np.array([m["frequency_hz"] for m in quarter["modes"][:n]])
        ff = np.array([m["frequency_hz"] for m in full["modes"][:n]])
        out["made_with"]["full_model_check"] = dict(
            configuration=configuration["name"],
            level=level.name,
            modes_compared=n,
            max_relative_difference=_sig(float(np.max(np.abs(fq - ff) / ff)), 3),
            full_model_wall_s=round(full["wall_s"], 1),
            quarter_models_wall_s=round(quarter["wall_s"], 1),
        )
        log(
            f"    quarter vs full, first {n} elastic modes: max rel. difference "
            f"{np.max(np.abs(fq - ff) / ff):.2e}"
        )
    out["made_with"]["runs"] = timings
    out["made_with"]["wall_time_s"] = round(time.perf_counter() - started, 1)
    text = spec_toml(name, case)
    check_spec(text)
    out["spec_toml"] = text
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--case", action="append", choices=sorted(CASES), help="case(s) to run (default: all)"
    )
    parser.add_argument("--quick", action="store_true", help="coarsest mesh only, to check the script")
    parser.add_argument(
        "--out", type=Path, help="output folder (default: this folder; a temporary one with --quick)"
    )
    parser.add_argument("--threads", type=int, default=1, help="threads for ccx (default 1)")
    parser.add_argument(
        "--no-full-check", action="store_true", help="skip the quarter-versus-full model check"
    )
    parser.add_argument("--keep", action="store_true", help="keep the ccx work folder")
    parser.add_argument("--levels", help="comma-separated mesh levels to run instead (e.g. tiny,coarse)")
    args = parser.parse_args(argv)
    if shutil.which("ccx") is None:
        parser.error("ccx (CalculiX) is not on the PATH; on Debian: apt-get install calculix-ccx")
    levels = LEVELS[:1] if args.quick else LEVELS
    if args.levels:
        known = {l.name: l for l in LEVELS + TRIAL_LEVELS}
        levels = tuple(known[n] for n in args.levels.split(","))
    trial = args.quick or args.levels
    out_dir = args.out or (Path(tempfile.mkdtemp(prefix="solid3d_quick_")) if trial else HERE)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in args.case or list(CASES):
        workdir = Path(tempfile.mkdtemp(prefix=f"ccx_{name}_"))
        print(f"{name}: work folder {workdir}", flush=True)
        try:
            result = run_case(
                name,
                levels,
                workdir,
                args.threads,
                not args.no_full_check,
                log=lambda s: print(s, flush=True),
            )
        finally:
            if not args.keep:
                shutil.rmtree(workdir, ignore_errors=True)
        path = out_dir / f"{name}.json"
        path.write_text(dumps(result) + "\n")
        print(f"{name}: wrote {path} ({result['made_with']['wall_time_s']:.0f} s)", flush=True)
        for c in result["configurations"]:
            flex = [m for m in c["modes"] if m["classification"] == "flexural"][:10]
            print(f"  {c['name']:10s} " + " ".join(f"{m['frequency_hz']:.1f}{m['label']}" for m in flex))
    return 0


if __name__ == "__main__":
    sys.exit(main())
