// The OpenGL API for the renderer's sources: core-profile prototypes, resolved by libglvnd's
// libOpenGL against whichever context (EGL or GLX) is current. No loader library.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
