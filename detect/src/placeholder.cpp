// Placeholder translation unit until detection lands (issue 6).
