/* test_file_mode.c — every output gets the same permissions: 0666 & ~umask
 * for a new file, the old mode for a replaced one (core/file_mode.h). The
 * viewer's images and camera paths used to be 0600 and the others 0644
 * whatever the umask. */
#include "test_support.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bake/bake_file.h"
#include "core/file_mode.h"
#include "io/image.h"
#include "view/campath.h"
#include "view/frame.h"

static mode_t mode_of(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        fail_msg("%s: not written", path);
    return st.st_mode & 07777;
}

/* Writes one of each kind of output into dir; returns their paths. */
static int write_outputs(const char *dir, char paths[5][700])
{
    sg_error err = {0};
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, 4, 3, &err), SG_OK);
    snprintf(paths[0], 700, "%s/image.exr", dir);
    snprintf(paths[1], 700, "%s/image.png", dir);
    snprintf(paths[2], 700, "%s/shot.png", dir);
    snprintf(paths[3], 700, "%s/path.txt", dir);
    snprintf(paths[4], 700, "%s/bake.sgbake", dir);
    assert_int_equal(sg_image_write(&img, paths[0], 1.0f, &err), SG_OK);
    assert_int_equal(sg_image_write(&img, paths[1], 1.0f, &err), SG_OK);
    unsigned char rgba[4 * 3 * 4] = {0};
    assert_int_equal(sg_view_write_png_rgba8(rgba, 4, 3, paths[2], &err), SG_OK);
    sg_campath p = {0};
    sg_campath_key k = {.time = 0.0, .view = {{0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 40.0f}};
    assert_int_equal(sg_campath_append(&p, &k, &err), SG_OK);
    assert_int_equal(sg_campath_write(&p, paths[3], &err), SG_OK);
    sg_campath_free(&p);
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc wd = {.path = paths[4], .scene_hash = 1, .param_hash = 2};
    assert_int_equal(sg_bake_writer_create(&wd, &w, &err), SG_OK);
    assert_int_equal(sg_bake_writer_commit(w, &err), SG_OK);
    sg_bake_writer_destroy(w);
    sg_image_free(&img);
    return 5;
}

static void test_outputs_follow_umask(void **state)
{
    (void)state;
    static const mode_t masks[] = {027, 022, 077};
    for (size_t m = 0; m < sizeof masks / sizeof masks[0]; m++) {
        char dir[700], paths[5][700];
        snprintf(dir, sizeof dir, "%s/mask%03o", sg_test_tmpdir(), (unsigned)masks[m]);
        mkdir(dir, 0777);
        mode_t old = umask(masks[m]);
        assert_int_equal(sg_umask(), masks[m]);
        int n = write_outputs(dir, paths);
        umask(old);
        for (int i = 0; i < n; i++)
            if (mode_of(paths[i]) != (0666 & ~masks[m]))
                fail_msg("umask %03o: %s has mode %03o, want %03o", (unsigned)masks[m], paths[i],
                         (unsigned)mode_of(paths[i]), (unsigned)(0666 & ~masks[m]));
    }
}

/* A replaced output keeps its mode (the user chmod-ed it). */
static void test_replaced_output_keeps_mode(void **state)
{
    (void)state;
    char dir[700], paths[5][700];
    snprintf(dir, sizeof dir, "%s/replace", sg_test_tmpdir());
    mkdir(dir, 0777);
    int n = write_outputs(dir, paths);
    for (int i = 0; i < n; i++)
        assert_int_equal(chmod(paths[i], 0604), 0);
    write_outputs(dir, paths);
    for (int i = 0; i < n; i++)
        if (mode_of(paths[i]) != 0604)
            fail_msg("%s: mode %03o after replacing, want 0604", paths[i], (unsigned)mode_of(paths[i]));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_outputs_follow_umask),
        cmocka_unit_test(test_replaced_output_keeps_mode),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
