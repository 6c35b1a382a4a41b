"""VTK time series for ParaView: the volume (NGSolve's VTKOutput: displacement, von Mises) and
every joint as a polyline through its Gauss points (D, kappa, opening, slip, tractions, the
upper face's displacement: warped, the deformed joint), each
with a .pvd collection so ParaView shows the crack beside the stresses."""
from __future__ import annotations

import pathlib

import numpy as np

from ..fe.pairing import upper_columns
from .files import atomic_write_text

__all__ = ["VTKWriter"]


def _vtp(x, y, fields: dict) -> str:
    n = x.size
    pts = " ".join(f"{a:.9g} {b:.9g} 0" for a, b in zip(x, y))
    data = "".join(f'<DataArray type="Float64" Name="{k}" '
                   f'NumberOfComponents="{1 if np.ndim(a) == 1 else np.shape(a)[1]}" '
                   'format="ascii">'
                   + " ".join(f"{v:.9g}" for v in np.asarray(a, float).ravel()) + "</DataArray>"
                   for k, a in fields.items())
    conn = " ".join(str(i) for i in range(n))
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1">'
            f'<PolyData><Piece NumberOfPoints="{n}" NumberOfLines="1">'
            f'<PointData>{data}</PointData>'
            f'<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{pts}'
            '</DataArray></Points>'
            f'<Lines><DataArray type="Int64" Name="connectivity" format="ascii">{conn}'
            f'</DataArray><DataArray type="Int64" Name="offsets" format="ascii">{n}'
            '</DataArray></Lines></Piece></PolyData></VTKFile>\n')


def _pvd(entries) -> str:
    rows = "".join(f'<DataSet timestep="{t:.9g}" file="{f}"/>' for t, f in entries)
    return ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">'
            f"<Collection>{rows}</Collection></VTKFile>\n")


class VTKWriter:
    def __init__(self, model, filename, joints=None):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        self.model = model
        self.joints = joints
        self.dir = pathlib.Path(filename).parent
        self.dir.mkdir(parents=True, exist_ok=True)
        self.gf = ngs.GridFunction(model.fes)
        self.vtk = ngs.VTKOutput(model.mesh,
                                 coefs=[model.displacement_cf(self.gf),
                                        model.von_mises(self.gf)],
                                 names=["displacement", "von_mises"],
                                 filename=str(filename), subdivision=0)
        self.frames = {} if joints is None else {n: [] for n in joints.names}
        self.k = 0
        # the upper face's displacement at each joint point (the rows of B on the columns of
        # the block above the joint): ParaView's "Warp By Vector" draws the deformed joint
        self.upper = {}
        if joints is not None:
            blocks = [r for r in model.regions if r != "rock"]
            B = model.interface.B
            for k, (name, sl) in enumerate(zip(joints.names, joints.slices)):
                cols = upper_columns(model, blocks[k])
                self.upper[name] = B[2 * sl.start:2 * sl.stop].multiply(cols[None, :]).tocsr()

    def write(self, u, t, solver=None):
        self.model.to_gridfunction(u, self.gf)
        self.vtk.Do(time=float(t))
        if self.joints is None or solver is None:
            return
        st, g, tr = solver.state, solver.g, solver.t
        for name, sl in zip(self.joints.names, self.joints.slices):
            f = f"joint_{name}_{self.k:06d}.vtp"
            up = (self.upper[name] @ u).reshape(-1, 2)       # (u . n, u . t) = (u_y, u_x)
            disp = np.column_stack([up[:, 1], up[:, 0], np.zeros(up.shape[0])])
            atomic_write_text(self.dir / f, _vtp(
                self.joints.x[sl], self.joints.y[sl],
                {"D": st.damage[sl], "kappa": st.kappa[sl], "opening": g[sl, 0],
                 "slip": g[sl, 1], "traction_N": tr[sl, 0], "traction_T": tr[sl, 1],
                 "displacement": disp}))
            self.frames[name].append((float(t), f))
            atomic_write_text(self.dir / f"joint_{name}.pvd", _pvd(self.frames[name]))
        self.k += 1

    def files(self) -> list[str]:
        return [f"{self.dir.name}/"]
