/* bake_mpi.h — splatgi-bake's only contact with MPI: who this process is
 * among the ranks of `mpirun -np N splatgi-bake ...`, the exchange a
 * distributed bake job needs (bake/bake_comm.h), and ending every rank.
 *
 * Two implementations, one chosen by CMake: bake_mpi.c (MPI found and
 * SG_MPI on) and bake_mpi_none.c (no MPI: always one process). Neither
 * makes MPI a requirement of a plain run: bake_mpi.c starts MPI only when
 * a launcher set its environment (Open MPI's OMPI_COMM_WORLD_SIZE, or
 * PMI_SIZE / PMIX_RANK of other launchers), so `splatgi-bake scene.json`
 * without mpirun never touches MPI.
 *
 * Test hook (bake_mpi.c only): SPLATGI_MPI_FAULT=RANK:N:error makes the
 * N-th exchange (counting from 1) of rank RANK fail with an error;
 * RANK:N:kill makes that rank kill itself with SIGKILL there, as a crashed
 * or killed node would; RANK:N:int sends that rank alone a SIGINT there (a
 * Ctrl-C that reached one rank: the others must stop at the same round).
 * tests/bake/splatgi_bake_mpi.sh uses all three.
 */
#ifndef SG_PRECOMPUTE_BAKE_MPI_H
#define SG_PRECOMPUTE_BAKE_MPI_H

#include "bake/bake_comm.h"

enum { SG_MPI_FAULT_ERROR = 0, SG_MPI_FAULT_KILL = 1, SG_MPI_FAULT_INT = 2 };

typedef struct sg_mpi {
    int active;        /* launched by an MPI launcher: MPI started        */
    int rank, size;    /* 0 and 1 when not active                         */
    sg_bake_comm comm; /* the exchange (active only)                      */
    int fault_rank;    /* SPLATGI_MPI_FAULT: the rank, -1 none            */
    long fault_at;     /* the exchange that fails (1 = first)              */
    int fault_kind;    /* SG_MPI_FAULT_*                                    */
    long exchanges;    /* exchanges so far                                 */
    double sent, received; /* bytes of this rank's pieces, of all pieces   */
    double seconds;    /* wall time inside exchanges (waiting included)     */
    char library[64];  /* "Open MPI v4.1.4", or "none"                      */
} sg_mpi;

/* Starts MPI when launched by an MPI launcher (above) and fills *m;
 * otherwise *m says one process. Returns 0 on success, else prints why on
 * stderr and returns nonzero (bad SPLATGI_MPI_FAULT, MPI_Init failed). */
int sg_mpi_start(int *argc, char ***argv, sg_mpi *m);

/* Ends every rank of the job with status `code` (MPI_Abort): the launcher
 * stops the others; never returns. Without MPI: exit(code). */
void sg_mpi_abort(const sg_mpi *m, int code);

/* Leaves MPI (MPI_Finalize) when active; returns rc. */
int sg_mpi_finish(sg_mpi *m, int rc);

#endif
