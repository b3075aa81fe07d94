"""Design samples from one evaluation of the partials equal the three separate ones."""

import numpy as np

import toolpath
from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from verification.samples import surface_points_normals


def test_one_pass_equals_point_and_derivatives():
    sections = toolpath.read_sections(bundled_data_path("dev_blade_15x142.csv"))
    surface = fit_streamline_surface(sections, tol=0.01)
    assert surface.kernel() is not None  # the compiled kernel's single pass
    t, s = np.linspace(0.0, 1.0, 41), np.linspace(0.0, 1.0, 23)
    points, normals, jac = surface_points_normals(surface, t, s, grid=True)
    np.testing.assert_array_equal(points, surface(t, s, grid=True))
    cross = np.cross(surface.derivative(t, s, dt=1, ds=0, grid=True),
                     surface.derivative(t, s, dt=0, ds=1, grid=True))
    np.testing.assert_array_equal(jac, np.linalg.norm(cross, axis=-1))
    np.testing.assert_allclose(normals, surface.orientation * cross / jac[..., None],
                               rtol=0, atol=1e-15)
