/* The viewer's JavaScript (three.js, Spark and third_party/viewer/viewer.js, bundled by
 * scripts/setup.sh into third_party/viewer/dist/viewer.js) inside the program, so a viewer
 * page is written with nothing read at run time and nothing downloaded at build time.
 * CMakeLists.txt defines GV_VIEWER_BUNDLE as the bundle's path when setup made it. */
#include "viewer_internal.h"

#ifdef GV_VIEWER_BUNDLE
/* .incbin copies the file's bytes into the object (GNU as and clang's assembler); a zero byte
 * after them ends the text. */
__asm__(".section .rodata\n"
        ".balign 16\n"
        "gv_viewer_bundle_start:\n"
        ".incbin \"" GV_VIEWER_BUNDLE "\"\n"
        "gv_viewer_bundle_end:\n"
        ".byte 0\n"
        ".previous\n");
extern const char gv_viewer_bundle_start[] __asm__("gv_viewer_bundle_start");
extern const char gv_viewer_bundle_end[] __asm__("gv_viewer_bundle_end");

const char *viewer_bundle(size_t *size)
{
    *size = (size_t)(gv_viewer_bundle_end - gv_viewer_bundle_start);
    return gv_viewer_bundle_start;
}
#else
const char *viewer_bundle(size_t *size)
{
    *size = 0;
    return NULL;
}
#endif
