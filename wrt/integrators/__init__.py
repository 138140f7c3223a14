"""Integrators: kernels that turn hit buffers into radiance, one module per integrator.

- :mod:`.path`: unbiased path tracing with next-event estimation and multiple importance sampling.
- :mod:`.whitted`: Whitted-style ray tracing: shadow rays to every light, mirror reflection and refraction.
- :mod:`.ao`: ambient occlusion.
- ``normals``, ``depth`` and ``albedo`` are quick looks computed from the AOVs in :mod:`wrt.render`.

:mod:`.emitters` holds the radiance that rays pick up from lights, shared by the path and whitted integrators.
The path and whitted kernels that draw lights are made per :class:`wrt.light_features.LightFeatures` (the kinds of
light a scene has), an integrator's kernels for one set of features in a Warp module of their own, so that a first
render compiles only the draws it needs.
"""

INTEGRATORS = ("whitted", "path", "ao", "normals", "depth", "albedo")  # names accepted by integrator=
LIGHT_SAMPLING_INTEGRATORS = ("whitted", "path")  # those that sample lights (the others read no light)
