// Viewport (Blender gpu module), preprocess pass: a quad covering the record textures.
void main()
{
    gl_Position = vec4(corner, 0.0, 1.0);
}
