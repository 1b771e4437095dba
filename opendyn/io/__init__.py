"""Reading robots and scenes: URDF files into Models, scene files into Scenes."""
