/* bake_mpi_none.c — bake_mpi.h without MPI (CMake found none, or SG_MPI is
 * off): always one process, never distributed. Under mpirun such a build
 * would run N independent whole bakes, so a launcher's environment is
 * refused with a message instead.
 */
#include "bake_mpi.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int sg_mpi_start(int *argc, char ***argv, sg_mpi *m)
{
    (void)argc;
    (void)argv;
    memset(m, 0, sizeof *m);
    m->size = 1;
    m->fault_rank = -1;
    snprintf(m->library, sizeof m->library, "none");
    const char *n = getenv("OMPI_COMM_WORLD_SIZE");
    if (n && strcmp(n, "1")) {
        fprintf(stderr, "splatgi-bake: launched by mpirun with %s ranks, but built without MPI "
                        "(cmake -DSG_MPI=ON with libopenmpi-dev installed)\n", n);
        return 1;
    }
    return 0;
}

void sg_mpi_abort(const sg_mpi *m, int code)
{
    (void)m;
    fflush(stdout);
    exit(code);
}

int sg_mpi_finish(sg_mpi *m, int rc)
{
    (void)m;
    return rc;
}
