/* The pieces of a bonded DEM sheet, shared by test_dem_leg and
 * test_dem_cone: spheres joined by intact bonds, labelled by union-find.
 * Include after core/dem.h. */
#ifndef SPHICE_TESTS_DEM_PIECES_H
#define SPHICE_TESTS_DEM_PIECES_H

static int uf_find(int *par, int i)
{
    while (par[i] != i) {
        par[i] = par[par[i]];
        i = par[i];
    }
    return i;
}

/* par (n entries) such that uf_find(par, i) is the smallest index of the
 * piece holding sphere i. */
static void dem_pieces(const dem *d, int *par)
{
    int n = (int)d->n;
    for (int i = 0; i < n; i++)
        par[i] = i;
    for (size_t k = 0; k < d->nbonds; k++)
        if (!d->bonds[k].broken) {
            int a = uf_find(par, d->bonds[k].i), b = uf_find(par, d->bonds[k].j);
            if (a != b)
                par[a < b ? b : a] = a < b ? a : b;
        }
}

#endif
