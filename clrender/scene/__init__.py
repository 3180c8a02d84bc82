"""What is rendered: scene files and dicts (scene), the camera, lights and materials, procedural
meshes (meshes) and glTF scenes (gltf)."""


def __getattr__(name):  # submodules load on first use: clrender.scene.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
