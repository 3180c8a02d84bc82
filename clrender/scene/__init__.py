"""What is rendered: scene files and dicts (scene), the camera, lights and materials, procedural
meshes (meshes) and glTF scenes (gltf)."""
