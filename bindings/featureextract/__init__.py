"""FeatureExtract: find every region of a target shape similar to a reference feature.

The method is Takashima & Kanai's (shape index + multi-radius SHOT key points, RANSAC projective
transform), extended as described in the project README. This package is a thin layer over the C++
core (`featureextract._core`); the same function serves the CLI, the FreeCAD workbench and scripts.

    import featureextract as fx
    ref = fx.read_shape("rib.step")
    tgt = fx.read_target("part.step", ref)          # tessellated finely enough for the feature
    result = fx.extract(ref, tgt, fx.make_params(seed=2))
    for m in result.matches:
        print(m.score, m.center, m.faces)

FE meshes (issue 5): fx.read_feature(folder) reads a reference feature (geometry, FE mesh, meshing
specification); fx.transfer_mesh(feature.mesh, match.transform, target) places the mesh on a found
instance (nodes on the target surface, quality before and after); fx.write_inp / fx.write_msh save it.

Long runs release the GIL; pass progress=callable(stage, fraction) and return False from it to cancel
(fx.Cancelled is raised); a run longer than its time_limit parameter raises fx.TimeLimitError (a
TimeoutError). Bad input raises fx.InputError (a ValueError) naming the file. STEP, IGES and BREP are
read in a child process, so a file that crashes OpenCASCADE raises InputError instead of killing the
interpreter (or FreeCAD).
"""
import os as _os

# OpenMP threads that wait spin by default and slow every search down when another program is busy
# on the machine (core/cli/main.cpp has the numbers); libgomp reads the policy once, when it is loaded
# (here, unless the process loaded it before: then this does nothing).
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from ._core import (Cancelled, Description, FeatureModel, FeMesh, InputError, Match, Mesh, Params, PreparedTarget,  # noqa: E402,F401
                    Result, ShapeStats, TimeLimitError, TransferredMesh, describe, element_quality, extract as _extract, param_table,
                    read_brep_string, read_feature, read_fe_mesh, read_shape, size_on_ladder, tessellation_for_feature, transfer_mesh,
                    write_inp, write_msh)

__all__ = ["Cancelled", "Description", "describe", "element_quality", "FeatureModel", "FeMesh", "InputError", "Match", "Mesh",
           "Params", "PreparedTarget", "Result", "ShapeStats", "TimeLimitError", "TransferredMesh", "extract", "make_params", "param_table",
           "read_brep_string", "read_feature", "read_fe_mesh", "read_shape", "read_target", "transfer_mesh", "write_inp",
           "write_msh"]


def make_params(**values):
    """Params with the engine's defaults, overridden by keyword (an unknown name or a bad value raises
    InputError, a ValueError, naming the parameter)."""
    p = Params()
    names = {row["name"] for row in param_table()}
    for k, v in values.items():
        if k not in names:
            raise InputError(f"unknown parameter '{k}'")
        setattr(p, k, v)
    return p


def read_target(path, reference):
    """Reads a target file tessellated for searching `reference` (a Mesh): the deflection is bounded by
    the reference's size, not only the target's."""
    rel, absolute = tessellation_for_feature(reference.diagonal)
    return read_shape(path, relative_deflection=rel, absolute_deflection=absolute)


def extract(reference, target, params=None, progress=None, **param_values):
    """All six steps: the instances of `reference` in `target` (Meshes, or a PreparedTarget to reuse
    its descriptors). Parameters as a Params or as keywords."""
    if params is None:
        params = make_params(**param_values)
    elif param_values:
        raise TypeError("give parameters either as params= or as keywords, not both")
    if isinstance(target, PreparedTarget):
        return target.extract(reference, params, progress)
    return _extract(reference, target, params, progress)
