//! Depth camera renderer (thesis Sec. 5.1.2, eq. 5.14): robot meshes, scene objects and people.
