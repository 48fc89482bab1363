// Placeholder translation unit until the GPU context lands (issue 4).
