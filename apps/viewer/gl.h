// The OpenGL API for the viewer's own drawing: core-profile prototypes, resolved by libglvnd's
// libOpenGL against the window's (GLX) context, as in libs/render. No loader library.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
